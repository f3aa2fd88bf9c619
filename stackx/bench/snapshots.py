"""A planar case's pictures in the report: the scene as it starts, and each solver's final state at the knob
value the summary shows, side by side in one view, so a toppled pyramid or a card house gone flat is seen
beside the numbers that judged it.

They are drawn by the renderers' own drawing (``stackx.render.draw``): the lab's Canvas, the view fitted to
all of them at once, so every picture is at the same scale, on a canvas shaped like the scene (``canvas``): a
stack of forty boxes is drawn tall and narrow, each box tens of pixels wide, not as a stripe in a square. The column's cases have their pictures in
``stackx run`` (``stack``, ``frames``, ``compare``) and get none here.
"""

from __future__ import annotations

from dataclasses import dataclass

from stackx.bench.compare import label, outcomes
from stackx.bench.markup import png_uri
from stackx.bench.result import CaseResult
from stackx.render.draw import bounds, framed, picture
from stackx.render.view import union
from stackx.render.style import Style

MODELS = ("planar",)  # the models whose cases get pictures in the report
LONG, SHORT = 480, 96  # pixels: a picture's longer side, and the least its shorter side gets


def canvas(states: list[object]) -> Style:
    """A fitted style whose canvas has the scene's shape (ground included): ``LONG`` pixels along its longer
    side, at least ``SHORT`` along the other."""
    x0, y0, x1, y1 = union(bounds(s, Style()) for s in states)
    wide, tall = max(x1 - x0, 1e-6), max(y1, 0.0) - min(y0, 0.0) or 1e-6
    if tall >= wide:
        return Style(fit=True, height=LONG, width=max(SHORT, round(LONG * wide / tall * 1.15)))
    return Style(fit=True, width=LONG, height=max(SHORT, round(LONG * tall / wide * 1.15)))


@dataclass(frozen=True)
class Snapshot:
    """One picture: what it shows (``caption``), whether that run passed (None: the start), and the PNG."""

    caption: str
    passed: bool | None
    uri: str


def snapshots(res: CaseResult, style: Style | None = None) -> list[Snapshot]:
    """The start and the final state of each shown run that has one (a run that blew up has none); empty for
    a case of a model not in ``MODELS``."""
    run = res.case.run
    if run.scene.model not in MODELS:
        return []
    start = run.scene.build()
    shown = [r for r in outcomes(res.records) if r.final is not None]
    states = [start, *(r.final for r in shown)]
    view = framed(states, style or canvas(states))
    captions = ["start", *(f"{label(r.solver, r.knob, r.value)}: {'passed' if r.passed else 'failed'}"
                           for r in shown)]
    passed = [None, *(r.passed for r in shown)]
    return [Snapshot(c, p, png_uri(picture(s, view).png_bytes())) for c, p, s in zip(captions, passed, states)]
