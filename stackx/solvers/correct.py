"""The lab's position correction, as a function of one contact."""

from stackx.kernel import kernel


@kernel
def correct(depth: float, slop: float, percent: float, inv_m1: float, inv_m2: float) -> tuple[float, float]:
    """How far to push two overlapping objects apart: ``(move of object 1 along -n, move of object 2 along +n)``.

    ``slop`` is the overlap left alone: without it a tiny correction happens every step and the pile jitters.
    ``percent`` is the share of the remaining overlap undone per step: 1.0 throws objects out and makes them
    oscillate, small values settle slowly (0.2 to 0.8 is usual). The move is split by inverse mass, so the
    lighter side moves more and an immovable side (inverse mass 0) does not move at all.

    The lab's ``max(depth - slop, 0) / total * percent``, with the zero case as an early return: the same
    numbers (a NaN depth still gives NaN), but compiled code then skips the arithmetic of a contact within
    slop instead of computing a zero move, which on a resting column made each contact wait for the one below.
    """
    total = inv_m1 + inv_m2
    if total == 0.0 or depth <= slop:
        return 0.0, 0.0
    c = (depth - slop) / total * percent
    return c * inv_m1, c * inv_m2
