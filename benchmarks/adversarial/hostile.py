"""Hostile files and values every file-reading attack class uses: YAML bombs and tags, bytes that are not text,
symlink loops, values no numeric field accepts; and the small helpers that edit a document by key path."""

from __future__ import annotations

import os
import random

import yaml


def bomb_yaml() -> str:
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 10):
        prev = chr(ord("a") + i - 1)
        cur = chr(ord("a") + i)
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    return "\n".join(lines) + "\n"


HOSTILE_YAML = {
    "billion-laughs alias bomb": lambda base: bomb_yaml() + base,
    "nesting 20000 levels": lambda base: base + "extra: " + "[" * 20000 + "]" * 20000 + "\n",
    "nesting 100 levels in a mapping": lambda base: base + "extra:" + "".join(
        "\n" + "  " * (i + 1) + f"k{i}:" for i in range(100)) + " 1\n",
    "400-digit integer": lambda base: base + "extra: " + "9" * 400 + "\n",
    "mapping used as a key": lambda base: base + "? {a: 1}\n: 2\n",
    "list used as a key": lambda base: base + "? [1, 2]\n: 2\n",
    "python object tag": lambda base: base + "extra: !!python/object/apply:os.system ['touch {marker}']\n",
    "custom tag": lambda base: base + "extra: !thing 3\n",
    "duplicate top-level key": lambda base: base + base.split("\n")[[i for i, l in enumerate(base.split("\n"))
                                                                      if l.startswith("format")][0]] + "\n",
    "truncated at 60%": lambda base: base[: int(len(base) * 0.6)],
    "top level is a list": lambda base: "- 1\n- 2\n",
    "top level is a scalar": lambda base: "just words\n",
    "empty file": lambda base: "",
    "only a document marker": lambda base: "---\n",
    "tab indentation": lambda base: base.replace("\n  ", "\n\t", 1),
    "unclosed flow mapping": lambda base: base + "extra: {a: 1\n",
    "multiple documents": lambda base: base + "---\n" + base,
}
HOSTILE_BYTES = {
    "binary garbage": lambda base: bytes(random.Random(7).randrange(256) for _ in range(4096)),
    "latin-1 bytes": lambda base: base.encode() + b"extra: caf\xe9\n",
    "NUL bytes": lambda base: base.encode() + b"\x00\x00\x00\n",
    "5 MiB file": lambda base: base.encode() + b"# " + b"x" * (5 * 1024 * 1024) + b"\n",
}

#: values that no numeric field of a procedure or rig file accepts
BAD_NUMBERS = {
    "a word": "ten",
    "NaN": float("nan"),
    "infinity": float("inf"),
    "1e300": 1e300,
    "a list": [1, 2],
    "a mapping": {"a": 1},
}


def hostile_files(ws, stem: str, base: str, suffix: str = ".yaml") -> list[tuple[str, object, object]]:
    """(mutation name, file, post-check) for every hostile YAML/bytes mutation of ``base``."""
    out = []
    for name, fn in HOSTILE_YAML.items():
        p = ws.path(f"{stem}-{name.replace(' ', '_')}", suffix)
        marker = ws.root / f"pwned-{p.stem}"
        p.write_text(fn(base).replace("{marker}", str(marker)))
        post = (lambda m=marker: f"the YAML tag ran code ({m} exists)" if m.exists() else None)
        out.append((name, p, post if "tag" in name else None))
    for name, fn in HOSTILE_BYTES.items():
        p = ws.path(f"{stem}-{name.replace(' ', '_')}", suffix)
        p.write_bytes(fn(base))
        out.append((name, p, None))
    loop = ws.path(f"{stem}-symlink_loop", suffix)
    os.symlink(loop, loop)
    out.append(("symlink loop", loop, None))
    d = ws.path(f"{stem}-a_directory", suffix)
    d.mkdir()
    out.append(("a directory", d, None))
    out.append(("missing file", ws.root / "in" / f"no-such-{stem}{suffix}", None))
    return out


def set_path(doc, path: str, value):
    """Set ``a.b[2].c`` in a nested mapping (creating mappings on the way)."""
    cur = doc
    parts = []
    for token in path.split("."):
        name, _, rest = token.partition("[")
        parts.append(name)
        for idx in ([int(x.rstrip("]")) for x in rest.split("[") if x] if rest else []):
            parts.append(idx)
    for p in parts[:-1]:
        cur = cur[p] if isinstance(p, int) else cur.setdefault(p, {})
    cur[parts[-1]] = value


def dump(doc) -> str:
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=1000)


def csv_rows(data: bytes) -> tuple[str, list[list[str]]]:
    text = data.decode()
    lines = text.splitlines()
    return lines[0], [line.split(",") for line in lines[1:]]


def csv_bytes(header: str, rows: list[list[str]], nl: str = "\n") -> bytes:
    return (nl.join([header] + [",".join(r) for r in rows]) + nl).encode()
