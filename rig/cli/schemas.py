"""Write or check the published JSON Schemas of the contracts (``docs/schemas/``): ``rig-procedure/1``,
``rig-file/1`` (with the sections the composition root wires in: ``sim:``, ``faults:``) and the
``rig-session/1`` manifest. One writer for all three, above every layer, so it sees the wired rig file.

    python -m rig.cli.schemas docs/schemas          # (re)write the published schemas
    python -m rig.cli.schemas --check docs/schemas  # exit 1 when one differs from the code

Editors with a YAML language server use them for completion and checking (docs/procedures.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rig.composition import wire
from rig.config import json_schema as config_schemas
from rig.lab import noise_profiles
from rig.session import json_schema as session_schema

PROG = "python -m rig.cli.schemas"


def published() -> dict:
    """file name -> function giving its text, for every published schema."""
    wire()
    out = {name: (lambda name=name: config_schemas.render(name)) for name in config_schemas.SCHEMAS}
    out[session_schema.FILE_NAME] = session_schema.render
    out[noise_profiles.SCHEMA_FILE] = noise_profiles.render_schema
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    ap.add_argument("directory", type=Path, help="where the *.schema.json files go (docs/schemas)")
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when a file differs")
    args = ap.parse_args(argv)
    stale = []
    for name, render in published().items():
        path, text = args.directory / name, render()
        if args.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(str(path))
            continue
        args.directory.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        print(path)
    if stale:
        print(f"out of date (run {PROG} {args.directory}): {', '.join(stale)}", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
