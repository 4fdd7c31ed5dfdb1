"""Hostile or broken YAML is refused at parse time with one line naming the file (exit 2), quickly: procedures,
rig files and session manifests all go through the one guarded loader (calib.file.yamlsafe)."""

from __future__ import annotations

import time

import pytest

from calib.file.yamlsafe import MAX_DEPTH, MAX_INT_DIGITS
from rig.config.procedure import load_procedure, load_procedure_text
from rig.config.rigfile import load_rig_file, parse_rig_file
from rig.errors import RigInputError, SessionFormatError
from rig.session import SessionManifest

from conftest import PROCEDURES, RIGS

SIX = (PROCEDURES / "six_position.yaml").read_text()
RIG = (RIGS / "sim.yaml").read_text()

BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))


def _one_line(fn, text, path):
    with pytest.raises(RigInputError) as exc:
        fn(text, path)
    msg = str(exc.value)
    assert msg.startswith(path) and "\n" not in msg, msg
    return msg


@pytest.mark.parametrize("fn,base,path", [(load_procedure_text, SIX, "p.yaml"), (parse_rig_file, RIG, "r.yaml")])
def test_an_alias_bomb_is_refused_at_parse_time_in_well_under_a_second(fn, base, path):
    t0 = time.perf_counter()
    msg = _one_line(fn, base + BOMB.replace("a:", "zz:", 1), path)
    assert time.perf_counter() - t0 < 0.5
    assert "alias" in msg


@pytest.mark.parametrize("nested", [
    "deep: " + "[" * 20000 + "]" * 20000 + "\n",
    "deep: " + "{a: " * 20000 + "1" + "}" * 20000 + "\n",
    "deep:\n" + "".join("  " * (i + 1) + "- \n" for i in range(3000)),
])
def test_twenty_thousand_levels_of_nesting_are_one_line(nested):
    t0 = time.perf_counter()
    msg = _one_line(load_procedure_text, SIX + nested, "p.yaml")
    assert "nested" in msg and time.perf_counter() - t0 < 0.5


def test_a_400_digit_integer_is_one_line_with_its_line():
    msg = _one_line(load_procedure_text, SIX.replace("seconds: 10", "seconds: " + "9" * 400), "p.yaml")
    assert msg.startswith("p.yaml:8:") and "digits" in msg


@pytest.mark.parametrize("key", ["? {a: 1}\n: 2\n", "? [a, b]\n: 2\n", "{a: 1}: 2\n"])
def test_a_mapping_or_list_used_as_a_key_is_one_line(key):
    assert "a key must be a plain value" in _one_line(parse_rig_file, RIG + key, "r.yaml")


def test_duplicate_keys_are_refused_in_rig_files_too():
    msg = _one_line(parse_rig_file, RIG.replace("home: zero", "home: zero\nhome: none"), "r.yaml")
    assert msg == "r.yaml:8: home: duplicate key"


@pytest.mark.parametrize("loader,name", [(load_procedure, "p.yaml"), (load_rig_file, "r.yaml")])
def test_binary_garbage_is_one_line_naming_the_file(tmp_path, loader, name):
    p = tmp_path / name
    p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff\xfe" + bytes(range(256)))
    with pytest.raises(RigInputError) as exc:
        loader(p)
    assert str(exc.value).startswith(str(p)) and "not a text file" in str(exc.value)


def test_control_characters_are_one_line():
    assert "not valid YAML" in _one_line(load_procedure_text, SIX + "x: \x00\x07\n", "p.yaml")


def test_binary_garbage_through_the_command_line_is_exit_2(tmp_path, capsys):
    from rig.cli import main
    p = tmp_path / "garbage.yaml"
    p.write_bytes(bytes(range(256)) * 4)
    code = main(["run", str(p), "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "garbage.yaml" in err[0]


#: name -> (text appended to a document, what its one line says, the line's offset from the document's end)
HOSTILE = {
    "an alias bomb": (BOMB.replace("a:", "zz:", 1), "aliases expand to more than", 9),
    "an undefined alias": ("zy: *x\n", "undefined alias", 1),
    "nesting one level too deep": ("zz: " + "[" * (MAX_DEPTH - 1) + "1" + "]" * (MAX_DEPTH - 1) + "\n",
                                   f"nested more than {MAX_DEPTH} levels deep", 1),
    "an integer of too many digits": ("zz: " + "9" * (MAX_INT_DIGITS + 1) + "\n", "digits", 1),
    "a tag on a mapping": ("zz: !!set {a, b}\n", "is not allowed (plain YAML only)", 1),
    "a python tag": ("zz: !!python/object/apply:os.system [ls]\n", "is not allowed (plain YAML only)", 1),
    "an empty !!int": ("zz: !!int ''\n", "not valid YAML: '' is not a valid !!int value", 1),
    "an empty !!float": ("zz: !!float ''\n", "is not a valid !!float value", 1),
    "a list as a key": ("? [a, b]\n: 1\n", "a key must be a plain value", 2),
    "a control character": ("zz: \x07\n", "not valid YAML", 1),
}


def _line(doc: str, offset: int) -> int:
    return doc.count("\n") - offset + 1


@pytest.mark.parametrize("name", HOSTILE)
def test_every_limit_in_a_procedure_is_exit_2_and_one_line_with_its_line(tmp_path, capsys, name):
    from rig.cli import main
    text, says, offset = HOSTILE[name]
    p = tmp_path / "p.yaml"
    p.write_text(SIX + text)
    assert main(["run", str(p), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"rig run: {p}:{_line(SIX + text, offset)}: ") and says in err[0], err


@pytest.mark.parametrize("name", HOSTILE)
def test_every_limit_in_a_rig_file_is_one_line_with_its_line(name):
    text, says, offset = HOSTILE[name]
    msg = _one_line(parse_rig_file, RIG + text, "r.yaml")
    assert msg.startswith(f"r.yaml:{_line(RIG + text, offset)}: ") and says in msg, msg


@pytest.mark.parametrize("name", HOSTILE)
def test_every_limit_in_a_session_manifest_is_one_line_with_its_line(tmp_path, name):
    text, says, offset = HOSTILE[name]
    manifest = "format: rig-session/1\nid: s\nstatus: complete\n" + text
    (tmp_path / "session.yaml").write_text(manifest)
    with pytest.raises(SessionFormatError) as exc:
        SessionManifest.load(tmp_path)
    msg = str(exc.value)
    assert msg.startswith(f"{tmp_path / 'session.yaml'}:{_line(manifest, offset)}: ") and says in msg, msg
    assert "\n" not in msg


def test_a_procedure_over_the_size_limit_is_one_line(tmp_path, capsys):
    from rig.cli import main
    p = tmp_path / "big.yaml"
    p.write_text(SIX + "# " + "x" * (1024 * 1024) + "\n")
    assert main(["run", str(p), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rig run: {p}: larger than 1 MiB: not a procedure"]


def test_the_history_reads_a_manifest_through_the_guarded_loader_too(tmp_path):
    from rig.lab.history import _read_manifest
    (tmp_path / "session.yaml").write_text("format: rig-session/1\n" + BOMB)
    t0 = time.perf_counter()
    with pytest.raises(RigInputError, match=r"session\.yaml:2: .*aliases expand to more than 10000 values"):
        _read_manifest(tmp_path)
    assert time.perf_counter() - t0 < 0.5
