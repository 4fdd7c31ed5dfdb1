"""Move planning: legal targets under soft limits and cable wrap, travel-cutting order, move times."""

from __future__ import annotations

import math

import numpy as np

from rig.errors import RigInputError


def plan_axis_target(current_deg: float, wanted_deg: float, soft_limits_deg, cable_wrap_deg: float,
                     axis: str = "") -> float:
    """Choose the stage target equivalent to ``wanted_deg`` (mod 360) with the shortest legal path.

    Parameters
    ----------
    current_deg : float
        Current stage position, deg (accumulated: the controller counter, not mod 360).
    wanted_deg : float
        Desired stage angle, deg; any ``wanted_deg + 360 k`` gives the same pose.
    soft_limits_deg : (float, float)
        Allowed stage positions, deg.
    cable_wrap_deg : float
        Largest allowed |accumulated rotation| from zero, deg.

    Raises
    ------
    RigInputError
        When no equivalent target is legal.
    """
    lo, hi = float(soft_limits_deg[0]), float(soft_limits_deg[1])
    lo, hi = max(lo, -cable_wrap_deg), min(hi, cable_wrap_deg)
    k0 = math.floor((current_deg - wanted_deg) / 360.0)
    candidates = [wanted_deg + 360.0 * k for k in range(k0 - 3, k0 + 5)]
    legal = [c for c in candidates if lo - 1e-9 <= c <= hi + 1e-9]
    if not legal:
        raise RigInputError(None, None, axis or None,
                            f"pose angle {wanted_deg:g} deg is unreachable within soft limits "
                            f"[{soft_limits_deg[0]:g}, {soft_limits_deg[1]:g}] deg and cable wrap +-{cable_wrap_deg:g} deg")
    return min(legal, key=lambda c: (abs(c - current_deg), abs(c)))


def move_time_s(distance_deg: float, speed_deg_s: float, accel_deg_s2: float) -> float:
    """Duration of a trapezoidal (or triangular) move, s."""
    d = abs(distance_deg)
    if d == 0:
        return 0.0
    t_acc = speed_deg_s / accel_deg_s2
    d_acc = speed_deg_s * t_acc  # accelerating + decelerating distance
    if d <= d_acc:
        return 2.0 * math.sqrt(d / accel_deg_s2)
    return 2.0 * t_acc + (d - d_acc) / speed_deg_s


def _angular_distance(a, b) -> float:
    d = (np.asarray(b) - np.asarray(a) + 180.0) % 360.0 - 180.0
    return float(np.max(np.abs(d)))


def reorder_for_travel(steps):
    """Greedy nearest-neighbour order of pose steps between temperature/prompt steps.

    Steps that are not poses stay where they are and bound the segments.
    """
    return _reorder_segments(steps, _greedy_order)


#: segments up to this many poses are ordered exactly (Held-Karp); longer ones greedily
EXACT_ORDER_MAX = 10


def reorder_fastest(steps):
    """The order of pose steps (between temperature/prompt steps) with the least total travel,
    travel being the largest axis turn of each move (all axes move at once, so that axis sets the
    move's time): exact for up to :data:`EXACT_ORDER_MAX` poses per segment, greedy beyond.

    Unlike :func:`reorder_for_travel` (greedy), this finds e.g. the six faces' order that needs only
    90 deg moves (+Z, +Y, +X, -Z, -X, -Y: 450 deg in all, against 540 deg for the seed's order).
    """
    def best(start, segment):
        return (_exact_order if len(segment) <= EXACT_ORDER_MAX else _greedy_order)(start, segment)
    return _reorder_segments(steps, best)


def _reorder_segments(steps, order_segment):
    """Apply ``order_segment(start_angles_deg, pose_steps) -> ordered`` to each run of pose steps;
    every other step stays where it is, and the next segment starts where the last one ended."""
    out, segment, pos = [], [], np.zeros(3)

    def flush():
        nonlocal pos
        order = order_segment(pos, segment)
        out.extend(order)
        if order:
            pos = np.asarray(order[-1].angles_deg)
        segment.clear()

    for s in steps:
        if s.kind == "static":
            segment.append(s)
        else:
            flush()
            out.append(s)
    flush()
    return out


def _greedy_order(start, segment):
    order, pos, remaining = [], start, list(segment)
    while remaining:
        nxt = min(remaining, key=lambda s: _angular_distance(pos, s.angles_deg))
        remaining.remove(nxt)
        order.append(nxt)
        pos = np.asarray(nxt.angles_deg)
    return order


def _exact_order(start, segment):
    """Held-Karp over the segment's poses from ``start`` (an open path: it may end anywhere)."""
    n = len(segment)
    if n <= 1:
        return list(segment)
    d0 = [_angular_distance(start, s.angles_deg) for s in segment]
    d = [[_angular_distance(a.angles_deg, b.angles_deg) for b in segment] for a in segment]
    best = {(1 << i, i): (d0[i], -1) for i in range(n)}
    for mask in range(1, 1 << n):
        for last in range(n):
            if (mask, last) not in best:
                continue
            cost = best[(mask, last)][0]
            for nxt in range(n):
                if mask & (1 << nxt):
                    continue
                key, c = (mask | (1 << nxt), nxt), cost + d[last][nxt]
                if key not in best or c < best[key][0] - 1e-9:
                    best[key] = (c, last)
    full = (1 << n) - 1
    last = min(range(n), key=lambda i: (best[(full, i)][0] + 1e-9 * i))
    order, mask = [], full
    while last != -1:
        order.append(segment[last])
        mask, last = mask ^ (1 << last), best[(mask, last)][1]
    return order[::-1]
