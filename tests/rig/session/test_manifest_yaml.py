"""The one guarded loader's fast path (``calib.file.yamlsafe.load``, libyaml's events) answers exactly as
its located path (``load_located``): the same value for every document, the same one-line refusal for every
bad or hostile one (the fast path reads only the plain documents ``yaml.safe_dump`` writes, every session
manifest and calibration file, and hands everything else to ``load_located``)."""

from __future__ import annotations

import datetime
import math
import random

import pytest
import yaml

from calib.file.yamlsafe import _load_plain, _NotPlain, load, load_located
from rig.errors import RigInputError
from rig.session.manifest import load_yaml

MANIFEST = """format: rig-session/1
id: six_position-20261125T152726Z-s1-22e5
created: '2026-11-25T15:27:26+00:00'
status: complete
seed: 1
procedure:
  name: six_position
  text: "format: rig-procedure/1\\nname: six_position\\nsensor: {accel_range_g: 4, sample_rate_hz: 100}\\n\\
    steps:\\n  - pose: \\"+Z up\\"\\nsolve: {model: triangular, method: pinv, thermal: auto}\\n"
software:
  name: rig-calibration
  version: 0.1.0
steps:
- index: 0
  name: +Z up
  kind: static
  angles_deg: [0.0, 0.0, -90.0]
  f_nominal:
  - 0.0
  - -0.7071067811865476
  - 1.0e-05
  status: complete
  stats: {n_samples: 1000, t_start_s: 1.005, noise_g: [0.0033, 3.3e-03, 1.0e+5], problems: [], attempts: 1}
rig:
  sensor: {model: MPU-9150, address: 0x68, accel_lsb_per_g: 8192.0, sample_rate_hz: 100, has_temperature: yes}
  odd:
    serial: 017
    note: ~
    when: 2001-12-14
    ratio: 1:30
    big: 1_000
    inf: .inf
    nan: .nan
    minus: -0
    plus: +5
    text: a?b:c#d
"""

SNIPPETS = ["[", "]", "{", "}", ":", ": ", "- ", "\t", "&a ", "*a", "!!str ", "!!int ", "? ", "#", "'", '"', "\n",
            "  ", "---\n", "...\n", "%YAML 1.1\n", "0x1F", "017", "1_000", "1:30", ".inf", ".nan", "1e5", "1.0e5",
            "yes", "~", "2001-12-14", "<<", "=", "\\", "\x85", "\u2028", "\x00", "\x07", "é", "µ", "\ufeff", "\r\n",
            "9" * 40, "-0", "+5", "1.", ".5"]


def outcome(reader, text: str):
    try:
        return "ok", reader(text)
    except Exception as exc:  # noqa: BLE001 - whatever load_located raises, the fast reader must raise too
        return "error", f"{type(exc).__name__}: {exc}"


def same(a, b) -> bool:
    """Equal values of equal types (dict order included), NaN equal to NaN."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    return a == b


def assert_answers_alike(text: str) -> None:
    slow = outcome(lambda t: load_located(t)[0], text)
    fast = outcome(load, text)
    assert slow[0] == fast[0], (text, slow, fast)
    assert same(slow[1], fast[1]) if slow[0] == "ok" else slow[1] == fast[1], (text, slow, fast)


def test_a_manifest_is_read_by_the_fast_path_to_the_same_values():
    assert same(_load_plain(MANIFEST), load_located(MANIFEST)[0])


@pytest.mark.parametrize("text", [
    "a: 1\na: 2\n",  # duplicate key
    "[" * 70 + "]" * 70,  # nested too deep (flow)
    "".join("  " * i + "- \n" for i in range(70)) + "  " * 70 + "x\n",  # nested too deep (block)
    "a: &x [1, 2]\nb: *x\n",  # an alias
    "a: !!python/object:os.system x\n",  # a tag
    "a: !!binary aGVsbG8=\n",
    "? [1, 2]\n: x\n",  # a key that is a list
    "a: " + "9" * 31 + "\n",  # an integer of too many digits
    "a: b\n---\nc: d\n",  # two documents
    "a:\tb\n",  # a tab (libyaml and PyYAML differ)
    "a: 'unterminated\n",
    "",
    "--- \n...\n",
    "- <<: {a: 1}\n",
])
def test_bad_and_hostile_documents_get_load_locateds_answer(text):
    assert_answers_alike(text)


def test_mutated_manifests_get_the_same_answer():
    rng = random.Random(0)
    for _ in range(600):
        text = MANIFEST if rng.random() < 0.5 else MANIFEST[:rng.randrange(len(MANIFEST))]
        for _ in range(rng.randrange(1, 4)):
            i = rng.randrange(len(text) + 1)
            text = (text[:i] + text[i + rng.randrange(1, 8):] if rng.random() < 0.3
                    else text[:i] + rng.choice(SNIPPETS) + text[i:])
        assert_answers_alike(text)


def random_value(rng: random.Random, depth: int = 0):
    kind = rng.random()
    if depth < 4 and kind < 0.2:
        return {random_key(rng): random_value(rng, depth + 1) for _ in range(rng.randrange(0, 5))}
    if depth < 4 and kind < 0.35:
        return [random_value(rng, depth + 1) for _ in range(rng.randrange(0, 5))]
    return rng.choice([
        rng.choice(SNIPPETS), rng.uniform(-1e6, 1e6) * 10.0 ** rng.randrange(-30, 30), float("inf"), float("nan"),
        -0.0, 5e-324, rng.randrange(-10**25, 10**25), True, None, datetime.datetime(2020, 1, 2, 3, 4, 5),
        "".join(rng.choice("abc xyz:-#01.'\"") for _ in range(rng.randrange(0, 12)))])


def random_key(rng: random.Random):
    return rng.choice([rng.choice(SNIPPETS), rng.randrange(100), f"k{rng.randrange(1000)}", 1.5, True, None])


def test_documents_safe_dump_writes_get_the_same_values():
    rng = random.Random(1)
    for _ in range(600):
        text = yaml.safe_dump(random_value(rng), allow_unicode=rng.random() < 0.5, sort_keys=False,
                              default_flow_style=rng.choice([None, True, False]), width=rng.choice([20, 80, 1000]))
        assert_answers_alike(text)


def test_the_fast_path_declines_what_it_does_not_read():
    for text in ("a: &x 1\nb: *x\n", "a: !!str 1\n", "a:\tb\n", "a: 1\na: 2\n", "--- a\n"):
        with pytest.raises(_NotPlain):
            _load_plain(text)


def test_the_manifest_reader_names_the_file_and_line_of_a_refusal():
    with pytest.raises(RigInputError) as exc:
        load_yaml("a: 1\nb: *x\n", "s/session.yaml")
    assert str(exc.value) == "s/session.yaml:2: not valid YAML: found undefined alias 'x'"
    assert load_yaml(MANIFEST, "s/session.yaml")["rig"]["odd"]["ratio"] == 90  # 1:30 is sexagesimal in YAML 1.1
