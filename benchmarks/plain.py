"""Plain-Python transcriptions of the same two solvers as ``steps.c``: lists of floats, one box at a time.

This is what the lab's step costs when written the way the lab text reads, the speed stackx is measured
against from below. Each function steps one column (``y``, ``v`` changed in place) and mirrors the C
transcription line for line, so all three (Python, C, stackx) must end on the same numbers.
"""

from __future__ import annotations


def _correct(depth: float, slop: float, percent: float, inv1: float, inv2: float) -> tuple[float, float]:
    total = inv1 + inv2
    if total == 0.0:
        return 0.0, 0.0
    c = max(depth - slop, 0.0) / total * percent
    return c * inv1, c * inv2


def _correct_positions(y: list[float], inv: list[float], half: list[float], slop: float, percent: float) -> None:
    _, up = _correct(half[0] - y[0], slop, percent, 0.0, inv[0])
    y[0] += up
    for i in range(len(y) - 1):
        down, up = _correct((half[i] + half[i + 1]) - (y[i + 1] - y[i]), slop, percent, inv[i], inv[i + 1])
        y[i] -= down
        y[i + 1] += up


def lab_run(y: list[float], v: list[float], inv: list[float], half: list[float], g: float, dt: float,
            iterations: int, corrects: bool, slop: float, percent: float, steps: int) -> None:
    """``steps`` lab steps: gravity, velocity passes (each visit clamped), positions, correction."""
    n = len(y)
    for _ in range(steps):
        for i in range(n):
            v[i] += g * dt
        for _ in range(iterations):
            if half[0] - y[0] > 0.0 and v[0] < 0.0 and inv[0] > 0.0:
                v[0] = 0.0
            for i in range(n - 1):
                depth = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
                rv = v[i + 1] - v[i]
                total = inv[i] + inv[i + 1]
                if depth > 0.0 and rv < 0.0 and total > 0.0:
                    j = -rv / total
                    v[i] -= j * inv[i]
                    v[i + 1] += j * inv[i + 1]
        for i in range(n):
            y[i] += v[i] * dt
        if corrects:
            _correct_positions(y, inv, half, slop, percent)


def warm_start_run(y: list[float], v: list[float], inv: list[float], half: list[float], g: float, dt: float,
                   iterations: int, corrects: bool, slop: float, percent: float, speculative: float,
                   impulse: list[float], steps: int) -> None:
    """``steps`` warm-started steps; ``impulse`` (one per contact, 0 = floor) carries over between calls."""
    n = len(y)
    mass = [0.0] * n
    target = [0.0] * n
    for _ in range(steps):
        for i in range(n):
            v[i] += g * dt
        for k in range(n):  # prepare: which contacts take part, and the slowest relative velocity each accepts
            d = half[0] - y[0] if k == 0 else (half[k - 1] + half[k]) - (y[k] - y[k - 1])
            total = inv[0] if k == 0 else inv[k - 1] + inv[k]
            if d > -speculative and total > 0.0:
                mass[k] = 1.0 / total
                target[k] = 0.0 if d > 0.0 else d / dt  # no bias: touching accepts no approach
            else:
                mass[k] = target[k] = impulse[k] = 0.0
        for k in range(n):  # warm start
            if impulse[k] != 0.0:
                if k > 0:
                    v[k - 1] -= impulse[k] * inv[k - 1]
                v[k] += impulse[k] * inv[k]
        for _ in range(iterations):
            for k in range(n):
                if mass[k] > 0.0:
                    rv = v[0] if k == 0 else v[k] - v[k - 1]
                    total = max(impulse[k] + mass[k] * (target[k] - rv), 0.0)
                    p = total - impulse[k]
                    if k > 0:
                        v[k - 1] -= p * inv[k - 1]
                    v[k] += p * inv[k]
                    impulse[k] = total
        for i in range(n):
            y[i] += v[i] * dt
        if corrects:
            _correct_positions(y, inv, half, slop, percent)
