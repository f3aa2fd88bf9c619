"""Plain-Python transcriptions of the same solvers as ``steps.c``: lists of floats, one box at a time.

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


def _prepare(y: list[float], inv: list[float], half: list[float], dt: float, speculative: float,
             impulse: list[float], mass: list[float], target: list[float]) -> None:
    """Which contacts take part (overlapping, or within ``speculative``) and the slowest relative velocity each
    accepts: none when touching (no bias), closing the gap within dt when apart. One sitting out forgets."""
    for k in range(len(y)):
        d = half[0] - y[0] if k == 0 else (half[k - 1] + half[k]) - (y[k] - y[k - 1])
        total = inv[0] if k == 0 else inv[k - 1] + inv[k]
        if d > -speculative and total > 0.0:
            mass[k] = 1.0 / total
            target[k] = 0.0 if d > 0.0 else d / dt
        else:
            mass[k] = target[k] = impulse[k] = 0.0


def warm_start_run(y: list[float], v: list[float], inv: list[float], half: list[float], g: float, dt: float,
                   iterations: int, carry: bool, corrects: bool, slop: float, percent: float, speculative: float,
                   impulse: list[float], steps: int) -> None:
    """``steps`` warm-started steps; ``impulse`` (one per contact, 0 = floor) carries over between calls."""
    n = len(y)
    mass = [0.0] * n
    target = [0.0] * n
    for _ in range(steps):
        for i in range(n):
            v[i] += g * dt
        _prepare(y, inv, half, dt, speculative, impulse, mass, target)
        for k in range(n):  # warm start, or forget
            if not carry:
                impulse[k] = 0.0
            elif impulse[k] != 0.0:
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


def _solve_column(v: list[float], inv: list[float], mass: list[float], target: list[float],
                  impulse: list[float]) -> None:
    """The exact velocity solve of one column: pool-adjacent-violators on velocities shifted by the targets,
    then each contact's impulse from the momentum changes."""
    n = len(v)
    u = list(v)
    shift = [0.0] * n
    first = [0] * (n + 2)
    weight, momentum, pins, pinned, value = ([0.0] * (n + 1) for _ in range(5))
    top, bottom, running = -1, 0, 0.0
    for i in range(n):
        if mass[i] > 0.0:
            running += target[i]
            if i == 0:
                top += 1
                first[top] = -1
                weight[top], momentum[top], pins[top], pinned[top], value[top] = 0.0, 0.0, 1.0, 0.0, 0.0
        else:
            running = 0.0
            bottom = top + 1
        shift[i] = running
        s = u[i] - running
        top += 1
        first[top] = i
        if inv[i] > 0.0:
            weight[top], momentum[top], pins[top], pinned[top] = 1.0 / inv[i], s / inv[i], 0.0, 0.0
        else:
            weight[top], momentum[top], pins[top], pinned[top] = 0.0, 0.0, 1.0, s
        value[top] = s
        while top > bottom and value[top - 1] > value[top]:
            weight[top - 1] += weight[top]
            momentum[top - 1] += momentum[top]
            pins[top - 1] += pins[top]
            pinned[top - 1] += pinned[top]
            top -= 1
            value[top] = pinned[top] / pins[top] if pins[top] > 0.0 else momentum[top] / weight[top]
    first[top + 1] = n
    block = [0] * n
    for b in range(top + 1):
        for i in range(max(first[b], 0), first[b + 1]):
            block[i] = b
            if inv[i] > 0.0 and first[b + 1] - first[b] > 1:
                v[i] = value[b] + shift[i]
    for k in range(n):
        impulse[k] = 0.0
    i = n - 1
    while i >= 0:  # impulses: zero between blocks, summed down from the top of each run of movable boxes
        if inv[i] == 0.0:
            i -= 1
            continue
        b = a = i
        while a > 0 and inv[a - 1] > 0.0 and mass[a] > 0.0 and block[a - 1] == block[a]:
            a -= 1
        top_pinned = b + 1 < n and mass[b + 1] > 0.0 and block[b + 1] == block[b]
        bottom_pinned = mass[a] > 0.0 and (first[block[a]] == -1 if a == 0 else block[a - 1] == block[a])
        total = lowest = 0.0
        for k in range(b, a - 1, -1):
            total += (v[k] - u[k]) / inv[k]
            impulse[k] = total
            lowest = min(lowest, total)
        carried = 0.0
        if top_pinned and not bottom_pinned:
            carried = -total
        elif top_pinned:
            carried = -lowest
        if top_pinned:
            impulse[b + 1] = carried
        for k in range(a, b + 1):
            impulse[k] += carried
        if not bottom_pinned:
            impulse[a] = 0.0
        i = a - 1


def exact_run(y: list[float], v: list[float], inv: list[float], half: list[float], g: float, dt: float,
              corrects: bool, slop: float, percent: float, speculative: float, steps: int) -> None:
    """``steps`` steps with the exact velocity solve: gravity, prepare, solve, positions, correction."""
    n = len(y)
    mass, target, impulse = [0.0] * n, [0.0] * n, [0.0] * n
    for _ in range(steps):
        for i in range(n):
            v[i] += g * dt
        _prepare(y, inv, half, dt, speculative, impulse, mass, target)
        _solve_column(v, inv, mass, target, impulse)
        for i in range(n):
            y[i] += v[i] * dt
        if corrects:
            _correct_positions(y, inv, half, slop, percent)
