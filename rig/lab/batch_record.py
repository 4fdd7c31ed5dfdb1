"""The batch record of a fixture run, ``batch.json`` (format ``rig-batch/1``, docs/fixture.md): its name, and
reading it back (``rig report BATCH_DIR``, the batch report).

The fixture run writes it (:class:`rig.workflow.batch.BatchRecord`); this module only names it and reads
it, so the lab's readers need nothing from the workflow.
"""

from __future__ import annotations

import json
from pathlib import Path

from rig.errors import RigInputError

#: the batch record's format and file name
BATCH_FORMAT = "rig-batch/1"
BATCH_FILE = "batch.json"
#: what a slot entry must have to be shown
SLOT_KEYS = ("slot", "serial", "outcome")


def is_batch(path) -> bool:
    """Whether ``path`` is a batch directory: a folder holding ``batch.json``."""
    return (Path(path) / BATCH_FILE).is_file()


def read_batch(batch_dir, *, finished: bool = True) -> dict:
    """``BATCH_DIR/batch.json`` read and checked (its format, a list of slots with their slot, serial and outcome).

    ``status`` (added by issue 30 item 6) is ``running`` while the batch runs, ``aborted`` once it stopped before
    its end, ``complete`` at its end (absent in records written before: complete); a slot still recording has
    ``outcome`` null. With ``finished`` (the readers of a batch's results) a batch that has not ended is refused.

    Raises RigInputError (one line naming the file and the key) for a record that cannot be read or is not
    ``rig-batch/1``, or (``finished``) of a batch that has not ended, with the command that resumes it.
    """
    path = Path(batch_dir) / BATCH_FILE
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise RigInputError(str(path), None, None, f"cannot read the batch record ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        line = getattr(exc, "lineno", None)
        raise RigInputError(str(path), line, None, f"not JSON ({getattr(exc, 'msg', exc)}): not a {BATCH_FORMAT} "
                            "record") from None
    if not isinstance(doc, dict) or doc.get("format") != BATCH_FORMAT:
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise RigInputError(str(path), None, "format", f"expected {BATCH_FORMAT}, got {got!r}")
    status = doc.get("status", "complete")
    if finished and status != "complete":
        raise RigInputError(str(path), None, "status", f"the batch has not ended (status {status}): resume it with "
                            f"rig run --resume {Path(batch_dir)}")
    slots = doc.get("slots")
    if not isinstance(slots, list):
        raise RigInputError(str(path), None, "slots", "expected a list of slots")
    for i, s in enumerate(slots):
        missing = [k for k in SLOT_KEYS if not isinstance(s, dict) or k not in s]
        if missing:
            raise RigInputError(str(path), None, f"slots[{i}]", f"expected {', '.join(SLOT_KEYS)}; missing "
                                f"{', '.join(missing)}")
    return doc


__all__ = ["BATCH_FILE", "BATCH_FORMAT", "is_batch", "read_batch"]
