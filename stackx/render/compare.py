"""The same scene under several solvers, side by side and in step: one player page over runs of an experiment.

Any config with several runs can add it, e.g. the lab's stack under three solvers:

```yaml
runs:
  lab: {}
  warm: {solver: {name: warm-start}}
  exact: {solver: {name: exact}}
outputs:
  - render: compare           # compare.html, and the pictures under compare/
    every: 15
    count: all
```

Each run is drawn every ``every`` steps into its own pictures (``frames``, a template with ``{run}`` and
``{index}``), and the page shows one panel per run, all on the same frame, with the player's controls
(``stackx.render.player.controlled_player_html``), the step and time of the frame, and under each picture the
top box's height (a planar world's highest box) and the deepest contact, where the solvers' differences show
before they are visible. The runs must step with the same dt, so that a frame is one instant for all of
them. A planar world's pictures share one view, fitted to every frame of every run, so the panels compare
at one scale.
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import Field

from stackx.errors import Fail
from stackx.outputs import Renderer, template_problem
from stackx.registry import renderers
from stackx.render.draw import DRAWN, describe, framed, picture
from stackx.render.player import Panel, controlled_player_html
from stackx.render.timeline import TimelineParams, frame_count, frame_steps, labels


class CompareParams(TimelineParams):
    path: str = Field("compare.html", description="the player page, inside the output folder")
    frames: str = Field("compare/{run}-{index:03d}.png", description="file name template of the pictures; {run} "
                                                                      "is the run's name, {index} counts frames from 0")
    runs: list[str] | None = Field(None, min_length=1, description="the runs to show side by side, in this order; "
                                                                   "default: every run of the experiment")


def flat(values: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """A solver's settings as dotted keys and values, nested sections opened and unset (null) ones left out:
    ``[("correction.percent", 0.2), ("iterations", 15)]``."""
    out: list[tuple[str, Any]] = []
    for key in sorted(values):
        value = values[key]
        if isinstance(value, dict):
            out += flat(value, f"{prefix}{key}.")
        elif value is not None:
            out.append((f"{prefix}{key}", value))
    return out


@renderers.register("compare")
class Compare(Renderer):
    """Several runs of one experiment played side by side, frame by frame in step."""

    Params = CompareParams
    models = DRAWN
    count: int
    runs: list[str]

    def steps(self) -> list[int]:
        return frame_steps(self.params, self.count)

    def names(self, run: str) -> list[str]:
        return [self.params.frames.format(run=run, index=k) for k in range(self.count)]

    def files(self) -> list[str]:
        return [name for run in self.runs for name in self.names(run)] + [self.params.path]

    def pictures(self) -> int:
        """How many pictures ``write`` draws: every frame of every run shown (``files`` less the page), known
        from the config's shape without naming them."""
        return len(self.runs) * self.count

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        self.runs = _shown(self.params.runs, [r.name for r in spec.runs], fail)
        by_name = {r.name: r for r in spec.runs}
        chosen = [by_name[name] for name in self.runs]
        first = chosen[0]
        other = next((r for r in chosen if r.dt != first.dt), None)
        if other is not None:
            raise fail(("runs",) if self.params.runs else (), f"runs {first.name!r} (dt {first.dt:g} s) and "
                       f"{other.name!r} (dt {other.dt:g} s) step differently: frames in step need one dt")
        shortest = min(chosen, key=lambda r: r.steps)
        self.count = frame_count(self.params, shortest.steps, fail, spec.limits.max_frames)
        if self.pictures() > spec.limits.max_frames:
            raise fail(("count",), _too_many_pictures(len(self.runs), self.count, spec.limits.max_frames))
        problem = template_problem(self.params.frames, {"run", "index"})
        if problem:
            raise fail(("frames",), problem)
        try:
            names = [n for run in self.runs for n in self.names(run)]
        except (KeyError, IndexError, ValueError) as exc:
            raise fail(("frames",), f"bad template: {exc}; use {{run}} and {{index}}, e.g. "
                                    "compare/{run}-{index:03d}.png") from None
        if len(set(names)) != len(names):
            raise fail(("frames",), "the template gives two pictures the same name; put {run} and {index} in it")
        if self.params.path in names:
            raise fail(("path",), f"{self.params.path!r} is also the name of a picture")

    def frame_steps(self, spec) -> set[int]:  # type: ignore[no-untyped-def]
        return set(self.steps())

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        steps = self.steps()
        by_name = {run.name: run for run in result.runs}
        style = framed([by_name[name].frames[k] for name in self.runs for k in steps], self.params.style)
        panels = []
        for name in self.runs:
            run = by_name[name]
            images = self.names(name)
            for image, step in zip(images, steps):
                out.write_bytes(image, picture(run.frames[step], style).png_bytes())
            settings = ", ".join(f"{k} {v if isinstance(v, str) else json.dumps(v)}"
                                 for k, v in flat(run.spec.solver_params.model_dump(mode="json")))
            panels.append(Panel(name, f"{run.spec.solver_cls.plugin_name}: {settings}", images,
                                [describe(run.frames[k]) for k in steps]))
        title = result.spec.description or result.spec.name
        dt = by_name[self.runs[0]].spec.dt
        page = controlled_player_html(title, panels, labels(steps, dt), self.params.interval_ms,
                                      (style.width, style.height))
        out.write_text(self.params.path, page)


def _shown(wanted: list[str] | None, known: list[str], fail: Fail) -> list[str]:
    """The runs to show, in order: ``wanted`` (each a run of the experiment, once) or every run. Checked with
    sets, in time linear in the runs: an experiment may have ``limits.max_runs`` of them."""
    if wanted is None:
        return list(known)
    names, seen = set(known), set()
    for i, name in enumerate(wanted):
        if name not in names:
            raise fail(("runs", i), f"unknown run {name!r}; runs: {', '.join(known)}")
        if name in seen:
            raise fail(("runs", i), f"run {name!r} is named twice")
        seen.add(name)
    return list(wanted)


def _too_many_pictures(runs: int, frames: int, limit: int) -> str:
    """Why a comparison is refused: its runs x frames pictures are over ``limits.max_frames``; the ways out."""
    return (f"{runs:,} runs x {frames:,} frames = {runs * frames:,} pictures, over limits.max_frames = {limit:,}; "
            "show fewer runs (runs: [...]) or frames, or raise the limit (limits: {max_frames: N})")
