"""The ``bench:`` section of a config: what ``stackx bench`` needs beyond the experiment itself.

A hard case is an ordinary config (scene, solver, dt, steps): ``stackx run`` runs it as usual and ignores
this section; ``stackx bench`` reads it for the pass criteria, the values of each solver's cost knob to
sweep, settings to give every solver that has them, and a claim of the lab to measure against the lab's
own settings. A config without the section is benched with the defaults.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from stackx.bench.criteria import Criteria

Knobs = Annotated[list[Annotated[int, Field(gt=0)]], Field(min_length=1)]
KNOB = [1, 2, 4, 8, 16, 32, 64]


class Claim(BaseModel):
    """A claim of the lab about a setting, measured by running the case's settings and the lab's side by side."""

    model_config = ConfigDict(extra="forbid")
    text: str = Field(min_length=1, description="the claim as the lab makes it, e.g. 'percent 1.0 oscillates'")
    baseline: dict[str, Any] = Field(min_length=1, description="the lab's settings to compare with: dotted "
                                                               "solver keys, e.g. correction.percent: 0.2")


class Timing(BaseModel):
    """How microseconds per step are measured: separate short runs, so a batched sweep still times each knob,
    both with every step in one call and with one step per call."""

    model_config = ConfigDict(extra="forbid")
    steps: int = Field(200, gt=0, le=1_000_000, description="steps per timed run, from the scene's start "
                                                           "(fewer when the case is shorter or an event comes first)")
    repeats: int = Field(5, gt=0, le=100, description="timed runs of each way of stepping: the fastest is "
                                                            "reported, with the spread of the others")


class BenchSection(BaseModel):
    """Settings of ``stackx bench`` for one case."""

    model_config = ConfigDict(extra="forbid")
    criteria: Criteria = Field(default_factory=Criteria, description="limits of holds, settled, never launched")
    knob: Knobs = Field(default_factory=lambda: list(KNOB),
                        description="values of every solver's cost knob (iterations or substeps) to run: "
                                    "more values cost more bench time")
    knobs: dict[str, Knobs] = Field(default_factory=dict,
                                    description="per solver name, knob values replacing 'knob'")
    set: dict[str, Any] = Field(default_factory=dict,
                                description="dotted solver keys given to every solver whose parameters have "
                                            "them (e.g. correction.percent: 1.0); others run at their defaults")
    claim: Claim | None = Field(None, description="a lab claim measured against the lab's settings")
    timing: Timing = Field(default_factory=Timing, description="how microseconds per step are measured")

    @field_validator("knob")
    @classmethod
    def _sorted(cls, knob: list[int]) -> list[int]:
        return sorted(set(knob))

    @field_validator("knobs")
    @classmethod
    def _each_sorted(cls, knobs: dict[str, list[int]]) -> dict[str, list[int]]:
        return {k: sorted(set(v)) for k, v in knobs.items()}
