"""Fault injection of the emulated controller: what can go wrong on the wire and in the mechanics."""

from __future__ import annotations

import random
from dataclasses import dataclass


@dataclass
class XimcFaults:
    """Fault injection (all off by default; rates are probabilities per answer).

    All fields are plain numbers, strings or bools so a rig file can set them.

    Attributes
    ----------
    crc_corrupt_rate : answer with a flipped CRC bit.
    drop_rate : send no answer.
    truncate_rate : send only part of the answer.
    latency_s : delay every answer (wall seconds).
    error_answer_rate, error_answer : answer ``errc``/``errd``/``errv`` instead.
    vanish_at_s, vanish_for_s : at clock time vanish_at_s the port disappears (as if unplugged),
        and a new one appears vanish_for_s wall seconds later (same ``stable_path``).
    stall_at_deg : motion stops dead at this physical angle (deg) with MVCMD_ERROR.
    limit_deg : a limit switch at this angle: stops there with MVCMD_ERROR and an edge flag.
    seed : seeds the random faults.
    """

    crc_corrupt_rate: float = 0.0
    drop_rate: float = 0.0
    truncate_rate: float = 0.0
    latency_s: float = 0.0
    error_answer_rate: float = 0.0
    error_answer: str = "errd"
    vanish_at_s: float | None = None
    vanish_for_s: float = 1.0
    stall_at_deg: float | None = None
    limit_deg: float | None = None
    seed: int = 0


def mangle_answer(answer: bytes, faults: XimcFaults, rng: random.Random) -> bytes:
    """The bytes actually sent for ``answer`` under ``faults`` (b"" when the answer is dropped).

    Draws from ``rng`` only for the faults whose rate is non-zero, in a fixed order:
    drop, error answer, CRC corruption (answers with data only), truncation.
    """
    f = faults
    if f.drop_rate and rng.random() < f.drop_rate:
        return b""
    if f.error_answer_rate and rng.random() < f.error_answer_rate:
        return f.error_answer.encode()
    if f.crc_corrupt_rate and len(answer) > 4 and rng.random() < f.crc_corrupt_rate:
        answer = answer[:-1] + bytes([answer[-1] ^ 0x01])
    if f.truncate_rate and rng.random() < f.truncate_rate:
        answer = answer[: max(1, len(answer) // 2)]
    return answer
