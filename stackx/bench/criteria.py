"""Pass criteria of the hard cases, judged from a finished run's measures.

A solver passes a case when, at the case's end, it
- **holds**: in the final state every contact, the floor's included, overlaps by at most ``depth_factor`` x
  ``slop`` and has at most that much gap (a column resting on air, as an engine's contact skin leaves it,
  does not hold); the top box is within ``rest_factor`` x ``slop`` per contact of where it rests on a rigid
  column (an average sinking that no single contact shows); and no box ever passed half-way into its
  neighbour or below the floor (the ``reach`` monitor stayed <= 1);
- is **settled**: the RMS of the boxes' actual motion over the final window (``rms_motion``) is below
  ``settle``;
- **never launched**: no box that had touched something (a contact overlapping, at zero depth or a hair
  apart: ``stackx.models.touch``) moved upward faster than ``launch``, measured from positions after every
  step (the ``launch`` monitor), whatever moved it: an impulse, a bias or a position correction that never
  touched a velocity.

Planar scenes are judged by the same three, with the checks that can fail on them: a check is made only when
its measure is there (the model measures it on this scene) and the model does not leave it out
(``Model.unjudged``). "Holds" adds **drift**: the boxes placed where they should stay (``drift_x``, the largest
horizontal motion, at most ``drift``; ``drift_angle``, the largest rotation, at most ``turn``) and, on a ramp,
the box's acceleration down the slope within ``slide`` of the analytic answer (``slide_error``): 0 where the
statics of a rigid box say it sticks, g (sin a - mu cos a) where they say it slides, and then flat, turned by at
most ``turn`` (``slide_turn``); a turn downhill of at least ``tip`` where they say it tips or pivots over its
downhill corner (``tip_turn``); a box pushed along the ground stops between the distance of the model's own
steps and v^2 / (2 mu g), to within ``stops`` of the latter (``stop_error``);
a box dropped to land on a face ends within ``turn`` of a multiple of 90 degrees (``land_tilt``), and every
box placed to topple ends at least ``fall`` from upright (``fall_tilt``); every box placed with its centre of
mass past its support's edge ends at least ``drop`` of its own heights lower (``drop``, "did not fall").
The top box's rest height is judged where a rigid pile gives it one (a stack, a pyramid, heavy on light), over
the contacts under it (``rest_contacts``; on the column every box's). A sliding box never settles, so
"settled" is not judged on it.

The limits are a config's ``bench.criteria`` section; the defaults are the hard cases' definitions.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field

if TYPE_CHECKING:
    from stackx.run.results import RunResult

NAMES = ("holds", "settled", "never_launched")
WORDS = {"max_depth": "overlaps", "max_gap": "gap", "reach": "crushed", "rms_motion": "moving",
         "launch": "launched", "drift_x": "drifted", "drift_angle": "turned", "slide_error": "slides wrong",
         "slide_turn": "turned", "tip_turn": "did not tip", "stop_error": "stops wrong", "drop": "did not fall"}
# a failed check in a word, the one word every output (``stackx run``, the bench's terminal and report) uses
# for it; |top_rest_error| is 'sunk' or 'high' by its sign (``word``)


class Criteria(BaseModel):
    """Limits of the three criteria."""

    model_config = ConfigDict(extra="forbid")
    slop: float = Field(0.01, ge=0, allow_inf_nan=False,
                        description="depth scale of 'holds' (m): the lab's slop, also where a solver runs with "
                                    "another slop, so every solver is held to the same limit")
    depth_factor: float = Field(2.0, gt=0, allow_inf_nan=False,
                                description="'holds' allows a final depth of depth_factor x slop")
    rest_factor: float = Field(1.5, gt=0, allow_inf_nan=False,
                               description="'holds' allows the top box to end up to rest_factor x slop per "
                                           "contact (boxes, the floor's included) away from its rigid rest height")
    reach: float = Field(1.0, gt=0, allow_inf_nan=False,
                         description="'holds' allows depths up to this share of the thinner box's half-height "
                                     "at every step (1: half-way into the neighbour)")
    settle: float = Field(1e-4, gt=0, allow_inf_nan=False,
                          description="'settled' needs the final RMS motion below this (m/s)")
    launch: float = Field(1.0, gt=0, allow_inf_nan=False,
                          description="'never launched' allows upward velocities up to this after touching (m/s)")
    drift: float = Field(0.05, gt=0, allow_inf_nan=False,
                         description="(planar) 'holds' allows a box placed at rest to end this far sideways from "
                                     "where it started (m)")
    turn: float = Field(0.05, gt=0, allow_inf_nan=False,
                        description="(planar) 'holds' allows a box placed at rest to end turned by this much (rad); "
                                    "a toppled box has turned by about 1.57")
    fall: float = Field(0.35, gt=0, allow_inf_nan=False,
                        description="(planar) 'holds' needs every box placed to topple (dominoes) to end tilted at "
                                    "least this far from upright (rad): 0.35 is 20 degrees, less than a domino "
                                    "leaning on the next leans")
    slide: float = Field(1e-3, gt=0, allow_inf_nan=False,
                         description="(planar ramp) 'holds' allows the box's acceleration down the slope to differ "
                                     "this much from g (sin a - mu cos a), or 0 where it should stick (m/s^2)")
    tip: float = Field(math.pi / 4, gt=0, allow_inf_nan=False,
                       description="(planar ramp) 'holds' needs a box that should tip or pivot over its downhill "
                                   "corner to end turned downhill at least this far (rad): 0.785 is half-way to "
                                   "its next face, which it lies on at 1.571; one that stood reads about 0")
    drop: float = Field(1.0, gt=0, allow_inf_nan=False,
                        description="(planar) 'holds' needs every box placed past its support's edge to end at "
                                    "least this many of its own heights lower than it started: 1 is off a "
                                    "ledge one box high; one that stayed on its support reads about 0")
    stops: float = Field(0.01, gt=0, allow_inf_nan=False,
                         description="(planar skid) 'holds' allows the box's stopping distance to lie outside "
                                     "[the model's steps' distance, v^2 / (2 mu g)] by this share of v^2 / (2 mu g)")

    @property
    def depth_limit(self) -> float:
        """The largest final depth, and the largest final gap, that 'holds' allows (m)."""
        return self.depth_factor * self.slop

    def rest_limit(self, contacts: int) -> float:
        """The largest distance of the top box from its rigid rest height that 'holds' allows (m)."""
        return self.rest_factor * self.slop * contacts


def digits(value: float, limit: float, least: int = 3) -> int:
    """Significant digits that show ``value`` and ``limit`` apart when they differ: ``least``, or as many
    more as it takes (a launch of 1.0034 against 1 needs 4: ``1.003 > 1``, never ``1 > 1``)."""
    n = least
    while n < 17 and value != limit and format(value, f".{n}g") == format(limit, f".{n}g"):
        n += 1
    return n


def near(value: float, limit: float) -> tuple[str, str]:
    """``value`` and ``limit`` as text, with the digits it takes to tell them apart (``digits``)."""
    n = digits(value, limit)
    return format(value, f".{n}g"), format(limit, f".{n}g")


@dataclass(frozen=True)
class Check:
    """One measure against its limit: at most the limit, or with ``strict`` below it; with ``least`` at least
    the limit. A NaN never passes."""

    measure: str
    value: float
    limit: float
    strict: bool = False
    least: bool = False

    @property
    def passed(self) -> bool:
        if self.least:
            return self.value >= self.limit
        return self.value < self.limit if self.strict else self.value <= self.limit

    def describe(self) -> str:
        """``max_depth 0.53 > 0.02``: the measure, its value and how it stands to the limit."""
        if self.least:
            return f"{self.measure} {self.value:.3g} {'>=' if self.passed else '<'} {self.limit:.3g}"
        rel = ("<" if self.strict else "<=") if self.passed else (">=" if self.strict else ">")
        value, limit = near(self.value, self.limit)
        return f"{self.measure} {value} {rel} {limit}"


@dataclass(frozen=True)
class Verdict:
    """One criterion: passed when all its checks passed; ``failing`` names what broke it."""

    name: str
    checks: tuple[Check, ...]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failing(self) -> str:
        """The failed checks, described; empty when the criterion passed."""
        return "; ".join(c.describe() for c in self.checks if not c.passed)

    def as_dict(self) -> dict[str, Any]:
        return {"passed": self.passed, "failing": self.failing,
                "checks": [{"measure": c.measure, "value": c.value, "limit": c.limit, "passed": c.passed}
                           for c in self.checks]}


def judge(measures: Mapping[str, Any], criteria: Criteria, unjudged: Collection[str] = ()) -> dict[str, Verdict]:
    """The three verdicts of one run from its measures (the column's: ``max_depth``, ``max_gap``,
    ``top_rest_error``, ``boxes``, ``reach``, ``rms_motion``, ``launch``; planar runs may lack some and add
    ``drift_x``, ``drift_angle``, ``slide_error``, ``slide_turn``, ``tip_turn``, ``stop_error``, ``rest_contacts``,
    ``land_tilt``, ``fall_tilt``, ``drop``). A check
    is made when its measure is there and not in ``unjudged``; a verdict without checks has nothing that could
    fail it and passes."""
    def check(measure: str, limit: float, strict: bool = False, least: bool = False) -> list[Check]:
        if measure not in measures or measure in unjudged:
            return []
        return [Check(measure, float(measures[measure]), limit, strict, least)]

    rest = []
    if "top_rest_error" in measures and "top_rest_error" not in unjudged:
        contacts = int(measures.get("rest_contacts", measures["boxes"]))
        rest = [Check("|top_rest_error|", abs(float(measures["top_rest_error"])), criteria.rest_limit(contacts))]
    holds = (*check("max_depth", criteria.depth_limit), *check("max_gap", criteria.depth_limit), *rest,
             *check("reach", criteria.reach), *check("drift_x", criteria.drift), *check("drift_angle", criteria.turn),
             *check("slide_error", criteria.slide), *check("slide_turn", criteria.turn),
             *check("tip_turn", criteria.tip, least=True),
             *check("stop_error", criteria.stops), *check("land_tilt", criteria.turn),
             *check("fall_tilt", criteria.fall, least=True), *check("drop", criteria.drop, least=True))
    return {
        "holds": Verdict("holds", holds),
        "settled": Verdict("settled", tuple(check("rms_motion", criteria.settle, strict=True))),
        "never_launched": Verdict("never_launched", tuple(check("launch", criteria.launch))),
    }


def passed(verdicts: Mapping[str, Verdict]) -> bool:
    """A case is passed when every criterion is."""
    return all(v.passed for v in verdicts.values())


def word(measure: str, measures: Mapping[str, Any]) -> str:
    """A failed check of ``measure`` in a word (``WORDS``): the top box's rest error is 'sunk' or 'high'."""
    if measure == "|top_rest_error|":
        return "sunk" if float(measures.get("top_rest_error", 0.0)) < 0 else "high"
    return WORDS.get(measure, measure)


def failed_words(verdicts: Mapping[str, Verdict], measures: Mapping[str, Any]) -> str:
    """What failed, in words: ``drifted, turned, launched``; empty when every criterion passed."""
    words = [word(c.measure, measures) for v in verdicts.values() for c in v.checks if not c.passed]
    return ", ".join(dict.fromkeys(words))


def states_outcome(scene: Any) -> bool:
    """Whether a scene states what must hold: boxes placed where they must stay (``rests``), a ramp whose
    box must stick, slide, tip or pivot as the statics say (``slope``), or a box that must stop where friction
    stops it (``stop``)."""
    return (bool(getattr(scene, "rests", list)()) or getattr(scene, "slope", lambda: None)() is not None
            or getattr(scene, "stop", lambda: None)() is not None)


def run_verdicts(result: RunResult, criteria: Criteria | None) -> tuple[dict[str, Verdict], dict[str, float]] | None:
    """The three verdicts of a finished run of ``stackx run``, judged as the bench judges it, and the measures
    they read, where there is something stated to judge: the config has a ``bench:`` section (``criteria``,
    its limits), or its scene states what must hold (``states_outcome``; judged with the default limits).
    None otherwise: a run that states nothing is not judged."""
    run = result.spec
    if criteria is None and not states_outcome(run.scene):
        return None
    found = {k: float(v) for k, v in result.measures.items() if isinstance(v, (int, float))}
    found.update(run.model.bench_measures(result, False))
    return judge(found, criteria or Criteria(), run.model.unjudged(run)), found

