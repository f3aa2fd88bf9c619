"""When a body counts as touching another: the one definition every model's monitors use.

"Never launched" judges only boxes that have touched something, so this decides which upward motion counts.
A contact touches when its depth is above ``-TOUCH_GAP``: overlapping, at exactly zero depth (a position
solver such as XPBD projects contacts there and leaves them), or a hair apart (an engine's contact skin:
Box2D 2.3 rests boxes about 0.015 m apart). ``TOUCH_GAP`` is the gap the default "holds" allows at the end
(2 x the lab's slop of 0.01 m): a box resting that far from another is resting on it. A box falling onto a
pile counts from the step it comes that close; only its upward motion after that is judged.
"""

from __future__ import annotations

from stackx.kernel import kernel

TOUCH_GAP = 0.02  # m: a contact with a gap of at most this (or any overlap) is touching


@kernel
def touching(depth: float) -> bool:
    """Whether a contact of ``depth`` (m, positive overlapping, negative a gap) touches."""
    return depth > -TOUCH_GAP
