"""The one guarded YAML loader (calib.file.yamlsafe): every limit, hit by a generated hostile document, is
one HostileYaml (one line, its line number) from both of its paths, quickly; a calibration file that hits it
is one CalibrationFileError naming the file. Just under each limit the document loads."""

from __future__ import annotations

import time

import pytest

from calib.errors import CalibrationFileError
from calib.file import calibration as calfile
from calib.file import yamlsafe
from calib.file.yamlsafe import MAX_BYTES, MAX_DEPTH, MAX_INT_DIGITS, HostileYaml, load, load_located, read_text

BASE = "format: rig-calibration/1\ncreated: '2026-01-01T00:00:00+00:00'\n"


# ``levels`` lists or mappings below the document's mapping, a number at the bottom: the number is at depth
# ``levels + 2`` (the document's mapping is depth 1), so MAX_DEPTH - 2 levels load and MAX_DEPTH - 1 do not
def _nested_lists(levels: int, leaf: str = "1") -> str:
    return "x: " + "[" * levels + leaf + "]" * levels + "\n"


def _nested_block(levels: int) -> str:
    return "x:\n" + "".join("  " * i + "- \n" for i in range(1, levels)) + "  " * levels + "- 1\n"


def _nested_mappings(levels: int) -> str:
    return "x: " + "{a: " * levels + "1" + "}" * levels + "\n"


BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))

#: name -> (document after BASE's two lines, what the one line says, its line number)
HOSTILE = {
    "alias bomb": (BOMB, "aliases expand to more than 10000 values", 3),  # the anchor that explodes
    "undefined alias": ("a: *nowhere\n", "undefined alias", 3),
    "flow nesting 20000 deep": (_nested_lists(20000), f"nested more than {MAX_DEPTH} levels deep", 3),
    "flow nesting one too deep": (_nested_lists(MAX_DEPTH - 1), f"nested more than {MAX_DEPTH} levels deep", 3),
    "mappings one too deep": (_nested_mappings(MAX_DEPTH - 1), f"nested more than {MAX_DEPTH} levels deep", 3),
    "block nesting 700 deep": (_nested_block(700), f"nested more than {MAX_DEPTH} levels deep", 3 + MAX_DEPTH),
    "block nesting one too deep": (_nested_block(MAX_DEPTH - 1), f"nested more than {MAX_DEPTH} levels deep",
                                   3 + MAX_DEPTH - 1),
    "an integer of 400 digits": ("n: " + "9" * 400 + "\n", f"a number of more than {MAX_INT_DIGITS} digits", 3),
    "an integer one digit too long": ("n: -" + "1_" + "9" * MAX_INT_DIGITS + "\n", "digits", 3),
    "a tagged integer of 31 digits": ("n: !!int " + "9" * 31 + "\n", "digits", 3),
    "duplicate key": ("session: a\nsession: b\n", "duplicate key", 4),
    "duplicate key spelt twice": ("1: a\n01: b\n", "duplicate key", 4),
    "a list as a key": ("? [a, b]\n: 1\n", "a key must be a plain value", 3),
    "a mapping as a key": ("{a: 1}: 2\n", "a key must be a plain value", 3),
    "a set": ("s: !!set {a, b}\n", "tag 'tag:yaml.org,2002:set' is not allowed", 3),
    "a python object": ("o: !!python/object:os.system {}\n", "is not allowed", 3),
    "a python name": ("o: !!python/name:os.system x\n", "could not determine a constructor", 3),
    "an empty !!int": ("a: !!int ''\n", "'' is not a valid !!int value", 3),
    "an empty !!float": ("a: !!float ''\n", "'' is not a valid !!float value", 3),
    "a !!bool of no truth": ("a: !!bool maybe\n", "'maybe' is not a valid !!bool value", 3),
    "a !!timestamp of no time": ("a: !!timestamp soon\n", "'soon' is not a valid !!timestamp value", 3),
    "a sign alone as !!int": ("a: !!int '-'\n", "is not a valid !!int value", 3),
    "an impossible date": ("a: 2001-13-45\n", "month must be in 1..12", 3),
    "a merge key": ("<<: {a: 1}\n", "not valid YAML", 3),
    "two documents": ("a: 1\n---\nb: 2\n", "not valid YAML", 4),
    "a control character": ("x: \x00\x07\n", "not valid YAML: unacceptable character", 3),
    "an unclosed list": ("x: [1, 2\n", "not valid YAML", 4),
}


@pytest.mark.parametrize("name", HOSTILE)
def test_every_limit_is_one_line_with_its_line_from_both_paths(name):
    text, says, line = HOSTILE[name]
    for path in (load, lambda t: load_located(t)[0]):
        t0 = time.perf_counter()
        with pytest.raises(HostileYaml) as exc:
            path(BASE + text)
        assert time.perf_counter() - t0 < 0.5
        assert says in str(exc.value) and "\n" not in str(exc.value) and exc.value.line == line, (exc.value.line,
                                                                                                  str(exc.value))


@pytest.mark.parametrize("name", HOSTILE)
def test_a_calibration_file_that_hits_a_limit_is_one_calibration_file_error(tmp_path, name):
    text, says, line = HOSTILE[name]
    path = tmp_path / "c.yaml"
    path.write_text(BASE + text)
    with pytest.raises(CalibrationFileError) as exc:
        calfile.read(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: line {line}: ") and says in msg and "\n" not in msg, msg


def test_an_empty_tagged_integer_is_refused_not_an_index_error():
    """``SafeConstructor.construct_yaml_int`` reads ``value[0]``: ``!!int ''`` used to escape as IndexError."""
    for text in ("a: !!int ''\n", "!!int '': 1\n", "- !!float ''\n", "a: {b: [!!int '']}\n"):
        for path in (load, lambda t: load_located(t)[0]):
            with pytest.raises(HostileYaml, match="is not a valid"):
                path(text)


@pytest.mark.parametrize("make", [_nested_lists, _nested_block, _nested_mappings])
def test_a_document_just_within_the_depth_limit_loads(make):
    doc = load(make(MAX_DEPTH - 2))
    assert doc == load_located(make(MAX_DEPTH - 2))[0]
    depth, node = 1, doc
    while isinstance(node, (dict, list)):
        node = node["x"] if depth == 1 else node[0] if isinstance(node, list) else node["a"]
        depth += 1
    assert depth == MAX_DEPTH and node == 1  # the number at the bottom is the 32nd level


def test_integers_of_the_longest_allowed_length_load():
    assert load("n: " + "9" * MAX_INT_DIGITS + "\n") == {"n": int("9" * MAX_INT_DIGITS)}
    assert load("n: -1_" + "0" * (MAX_INT_DIGITS - 1) + "\n") == {"n": -(10 ** (MAX_INT_DIGITS - 1))}


def test_anchors_without_aliases_and_plain_tags_load():
    assert load("a: &x 1\nb: !!str 2\nc: !!omap [{k: 1}]\n") == {"a": 1, "b": "2", "c": [{"k": 1}]}


def test_the_file_size_limit(tmp_path):
    p = tmp_path / "f.yaml"
    p.write_bytes(b"a: 1\n" + b"#" * (MAX_BYTES - 6) + b"\n")
    assert load(read_text(p)) == {"a": 1}
    p.write_bytes(b"a: 1\n" + b"#" * (MAX_BYTES - 5) + b"\n")
    with pytest.raises(HostileYaml, match="larger than 1 MiB: not a procedure"):
        read_text(p, "procedure")
    assert read_text(p, max_bytes=2 * MAX_BYTES).startswith("a: 1\n")  # a kind of file allowed more


def test_a_device_that_never_ends_is_refused_at_the_limit():
    t0 = time.perf_counter()
    with pytest.raises(HostileYaml, match="larger than"):
        read_text("/dev/zero")
    assert time.perf_counter() - t0 < 2


def test_text_that_is_not_utf8_is_refused_naming_the_byte(tmp_path):
    p = tmp_path / "f.yaml"
    p.write_bytes(b"a: 1\nb: \xff\xfe\n")
    with pytest.raises(HostileYaml, match=r"not a text file \(byte 8 is not UTF-8\)"):
        read_text(p)


def test_newlines_are_read_as_open_reads_them(tmp_path):
    p = tmp_path / "f.yaml"
    p.write_bytes(b"a: 1\r\nb: 2\rc: 3\n")
    assert read_text(p) == "a: 1\nb: 2\nc: 3\n"


def test_the_limits_are_the_stricter_of_the_two_loaders_that_were():
    """calib's loader (32 levels, 1 MiB, no aliases) and rig's (64 levels, 4 MiB, aliases up to 10,000
    values) became this one: the stricter depth and size; aliases bounded by what they expand to (a rig
    file that shares one axis's settings by an anchor is plain practice, a bomb is not)."""
    assert (MAX_DEPTH, MAX_BYTES, MAX_INT_DIGITS) == (32, 1024 * 1024, 30)
    assert yamlsafe.MAX_ALIAS_VALUES == 10_000


def test_an_anchor_shared_by_a_few_keys_loads_as_copies():
    doc, lines = yamlsafe.load_located("base: &axis {speed_deg_s: 20, accel_deg_s2: 40}\na1: *axis\na2: *axis\n")
    assert doc["a1"] == doc["a2"] == doc["base"] == {"speed_deg_s": 20, "accel_deg_s2": 40}
    doc["a1"]["speed_deg_s"] = 5  # copies: changing one changes no other
    assert doc["a2"]["speed_deg_s"] == 20 and yamlsafe.load("a: &x [1, 2]\nb: *x\n") == {"a": [1, 2], "b": [1, 2]}
