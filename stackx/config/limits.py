"""Limits of a run: what counts as a blow-up, and how big a run may be before it is refused.

A config may carry a top-level ``limits:`` section; every key has a default, so most configs never write it.
The size limits are checked when the config is loaded, before anything steps, so a run that could not fit
in memory or finish in reasonable time fails at once with the config's ``file:line:col`` instead of after
an hour or with the machine swapping. ``max_speed`` is checked while stepping (see ``stackx.run.watch``), the size limits by
``stackx.config.sizing``. How long a config's text may be is not a limit here: it is read before this section
(``stackx.config.yamlsrc.MAX_TEXT_BYTES``).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class Limits(BaseModel):
    """Bounds that stop a run: speed while stepping, memory and work before stepping."""

    model_config = ConfigDict(extra="forbid")
    max_speed: float = Field(
        1000.0, gt=0, allow_inf_nan=False,
        description="fastest a box may move (m/s) before the run is stopped as blown up; a box dropped from "
                    "h metres lands at sqrt(2*9.8*h) m/s, 140 m/s from a kilometre, so the default only "
                    "trips on a solver that has gone unstable. Checked between solver calls (a few hundred "
                    "steps apart at most, and at every recorded step), then narrowed to the first step over it: a "
                    "speed that stays over the limit is caught, a spike that settles within one call is not")
    max_memory_mb: float = Field(
        4096.0, gt=0, allow_inf_nan=False,
        description="most memory (MiB) the recorded states of one experiment may take (states kept for "
                    "frames, events and the final motion window, for every run and box)")
    max_bodies: int = Field(
        10_000, gt=0, description="most boxes one run's scene may hold (listed or generated); the largest shipped "
                                  "scene has 1,000")
    max_box_steps: float = Field(
        1e9, gt=0, allow_inf_nan=False,
        description="most steps x boxes one run may ask for: 1e9 is minutes to hours of stepping; the largest "
                    "shipped case (recovery-1000) asks for 1.2e7")
    max_frames: int = Field(
        10_000, gt=0, description="most pictures one experiment may draw, summed over its renderers (each is a "
                                  "recorded state and a file); a comparison draws its frames for every run it "
                                  "shows, runs x frames pictures")
    max_runs: int = Field(
        10_000, gt=0, description="most runs one experiment may have: the runs it names, or the number of points "
                                  "of a sweep's grid (the product of its lists' lengths), checked before any run "
                                  "is made")
    max_work: float = Field(
        1e12, gt=0, allow_inf_nan=False,
        description="most box-steps times solver passes (iterations x substeps) one experiment may ask for; "
                    "1e12 is hours of compiled stepping")
