"""Which steps a renderer of moving pictures draws: from ``start``, every ``every`` steps, ``count`` of them or
all up to the end of the run; and how a player labels each one (its step and its time)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, PlainValidator, WithJsonSchema

from stackx.errors import Fail
from stackx.render.style import Styled

MAX_FRAMES = 100_000


def _count(value: Any) -> int | str:
    """A number of frames, or ``all``. One check, not a union of two types, so a refusal names the key itself
    (a union's error would name the member it was tried against)."""
    if value == "all":
        return "all"
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 < value <= MAX_FRAMES:
        raise ValueError(f"a number of frames from 1 to {MAX_FRAMES:,}, or 'all' (got {value!r})")
    return value


Count = Annotated[int | Literal["all"], PlainValidator(_count), WithJsonSchema(
    {"anyOf": [{"type": "integer", "minimum": 1, "maximum": MAX_FRAMES}, {"const": "all"}]})]


class TimelineParams(Styled):
    """When the pictures are taken, and how fast a player shows them."""

    start: int = Field(0, ge=0, description="step of the first frame (the state before that step)")
    every: int = Field(gt=0, description="steps between frames")
    count: Count = Field(description="number of frames, or 'all': every frame from start to the end of the run "
                                     "(the whole settling; more frames, more files)")
    interval_ms: int = Field(250, gt=0, le=60_000, description="time each frame is shown in the player at 1x speed")


def frame_count(params: TimelineParams, steps: int, fail: Fail, limit: int = MAX_FRAMES) -> int:
    """The number of frames of a run of ``steps`` steps; a last frame past the end, or more frames than
    ``limit`` (``limits.max_frames``), is refused at ``count``."""
    if params.start > steps:
        raise fail(("start",), f"the first frame would be at step {params.start}, past the end of the run ({steps})")
    if params.count == "all":
        count = (steps - params.start) // params.every + 1
        if count > limit:
            raise fail(("count",), f"'all' is {count:,} frames (every {params.every} steps from {params.start} to "
                                   f"step {steps}), over limits.max_frames = {limit:,}; draw fewer (a larger "
                                   "'every' or a number), or raise the limit (limits: {max_frames: N})")
        return count
    if params.count > limit:
        raise fail(("count",), f"{params.count:,} frames, over limits.max_frames = {limit:,}; draw fewer, or raise "
                               "the limit (limits: {max_frames: N})")
    last = params.start + (params.count - 1) * params.every
    if last > steps:
        raise fail(("count",), f"the last frame would be at step {last}, past the end of the run ({steps})")
    return params.count


def frame_steps(params: TimelineParams, count: int) -> list[int]:
    """The step of each frame: the state before that step is drawn."""
    return [params.start + k * params.every for k in range(count)]


def labels(steps: list[int], dt: float) -> list[str]:
    """``step 15 · t = 0.250 s`` for each frame: the state before step k is at time k x dt."""
    return [f"step {k} · t = {k * dt:.3f} s" for k in steps]
