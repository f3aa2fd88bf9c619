"""The column scene: boxes on a floor, listed one by one or generated as an evenly spaced stack.

A scene may also take boxes away during a run (``remove``): the load-removal case lifts the heavy top box
off a resting column and watches whether the rest is thrown up by what the solver remembers of the load.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from stackx.registry import scenes
from stackx.scenes import Event, Scene


class Box(BaseModel):
    """One box of the column."""

    model_config = ConfigDict(extra="forbid")
    y: float = Field(description="centre height at the start (m)", allow_inf_nan=False)
    v: float = Field(0.0, description="vertical velocity at the start (m/s, up is positive)", allow_inf_nan=False)
    mass: float = Field(1.0, gt=0, allow_inf_nan=False, description="mass (kg); the solver uses 1/mass")
    half_height: float = Field(0.5, gt=0, allow_inf_nan=False, description="half of the box's height (m)")


class Stack(BaseModel):
    """``count`` equal boxes, the bottom one centred at ``y0``, the others ``spacing`` apart."""

    model_config = ConfigDict(extra="forbid")
    count: int = Field(gt=0, le=1_000_000, description="number of boxes")
    y0: float = Field(allow_inf_nan=False, description="centre height of the bottom box (m)")
    spacing: float = Field(gt=0, allow_inf_nan=False, description="distance between neighbouring centres (m)")
    v: float = Field(0.0, allow_inf_nan=False, description="velocity of every box at the start (m/s)")
    mass: float = Field(1.0, gt=0, allow_inf_nan=False, description="mass of every box (kg)")
    half_height: float = Field(0.5, gt=0, allow_inf_nan=False, description="half-height of every box (m)")


class Removal(BaseModel):
    """Take one box away between two steps, as if lifted off instantly."""

    model_config = ConfigDict(extra="forbid")
    step: int = Field(gt=0, le=100_000_000, description="the box is gone before this step (after this many steps)")
    box: int = Field(-1, description="which box, bottom first among the boxes left at that time; "
                                     "negative counts from the top (-1: the top box)")


class ColumnParams(BaseModel):
    """Either ``boxes`` (a list, bottom first) or ``stack`` (a generated column); optionally ``remove``."""

    model_config = ConfigDict(extra="forbid")
    boxes: list[Box] | None = Field(None, min_length=1, description="the boxes, bottom first")
    stack: Stack | None = Field(None, description="an evenly spaced column of equal boxes")
    remove: list[Removal] = Field(default_factory=list,
                                  description="boxes taken away during the run, in step order")

    @model_validator(mode="after")
    def _one_of(self) -> ColumnParams:
        if (self.boxes is None) == (self.stack is None):
            raise ValueError("give exactly one of 'boxes' (a list) or 'stack' (count, y0, spacing)")
        return self

    @field_validator("remove")
    @classmethod
    def _removals(cls, remove: list[Removal], info: ValidationInfo) -> list[Removal]:
        boxes, stack = info.data.get("boxes"), info.data.get("stack")
        if boxes is None and stack is None:
            return remove  # reported by _one_of
        left = len(boxes) if boxes is not None else stack.count
        for i, r in enumerate(remove):
            if i and r.step <= remove[i - 1].step:
                raise ValueError(f"remove[{i}]: steps must increase (step {r.step} after step "
                                 f"{remove[i - 1].step})")
            if not -left <= r.box < left:
                raise ValueError(f"remove[{i}]: box {r.box} does not exist; {left} boxes are left at step "
                                 f"{r.step} (0..{left - 1}, or -1 for the top)")
            if left == 1:
                raise ValueError(f"remove[{i}]: cannot take away the last box")
            left -= 1
        return remove

    @field_validator("boxes")
    @classmethod
    def _bottom_up(cls, boxes: list[Box] | None) -> list[Box] | None:
        for i in range(1, len(boxes or [])):
            if not boxes[i].y > boxes[i - 1].y:  # type: ignore[index]
                raise ValueError(f"boxes are listed bottom first: box {i} (y={boxes[i].y}) "  # type: ignore[index]
                                 f"must be above box {i - 1} (y={boxes[i - 1].y})")  # type: ignore[index]
        return boxes

    def box_list(self) -> list[Box]:
        if self.boxes is not None:
            return self.boxes
        s = self.stack
        assert s is not None
        return [Box(y=s.y0 + i * s.spacing, v=s.v, mass=s.mass, half_height=s.half_height) for i in range(s.count)]


@scenes.register("column")
class Column(Scene):
    """Boxes stacked bottom-up on a floor at y = 0, moving only vertically: the lab's scenes."""

    Params = ColumnParams
    model = "column"

    def build(self):  # type: ignore[override]
        import numpy as np

        from stackx.models.column.state import ColumnState

        boxes = self.params.box_list()
        row = lambda f: np.array([[f(b) for b in boxes]], dtype=np.float64)  # noqa: E731
        return ColumnState(row(lambda b: b.y), row(lambda b: b.v), row(lambda b: 1.0 / b.mass),
                           row(lambda b: b.half_height))

    def size(self) -> int:
        """Number of boxes at the start, known without building arrays (for checks before stepping)."""
        p = self.params
        return len(p.boxes) if p.boxes is not None else p.stack.count

    def final_size(self) -> int:
        return self.size() - len(self.params.remove)

    def events(self) -> tuple[RemoveBox, ...]:
        """The removals, each with its box index resolved against the boxes left at its step."""
        left, out = self.size(), []
        for i, r in enumerate(self.params.remove):
            out.append(RemoveBox(r.step, r.box % left, origin=("remove", i)))
            left -= 1
        return tuple(out)


@dataclass(frozen=True)
class RemoveBox(Event):
    """Take box ``box`` away before step ``step``.

    The box vanishes from the state (its neighbours, if any, now face each other) and from the solver's
    per-box and per-contact memory: the contact under the removed box goes with it, and the contact above
    it becomes the contact between its two neighbours, keeping what the solver remembered of it (it carried
    the same load). The run's monitors keep their history (peak depth, reach, launch include the removed
    box until it left); ``touched`` loses the box's entry.
    """

    box: int

    def apply(self, state: Any, solver: Any) -> None:
        solver.remove_box(state, self.box)
        state.remove_box(self.box)


