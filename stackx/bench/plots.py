"""The report's pictures, drawn with matplotlib's Agg backend (no display, no network), as PNG bytes.

matplotlib is imported here only, so nothing but ``stackx bench`` pays for it. Every solver has its colour
from ``stackx.bench.palette`` in every picture.

- **Speed against error**, one per case. Log-log axes: microseconds per step across, RMS velocity error
  against the exact solver up; one line per solver through its knob values (labelled), filled markers where
  the run passed the case and hollow where it failed, and the Pareto front of the runs that passed (no
  other passing run both faster and more accurate) as a grey band with ringed points. The reference is not a
  point: its error is zero by definition, and drawing it at some floor such as 1e-15 would give most of
  the height to nothing. It is a dashed vertical line at its time per step. Runs whose error is below
  ``AS_EXACT`` (rounding: they solved every step as the reference did) sit on a thin band at the bottom
  of the axis, just under the smallest error above it, so the axis spans only the errors that differ.
  Markers that would land on each other (two solvers with the same error at nearly the same speed, as when
  both solve every step exactly) are drawn as concentric rings: each is widened by ``RING`` points for every
  marker drawn over it, so no solver's run is hidden under another's. Errors read beside their uncertainty
  (``stackx.bench.uncertainty``): a run is drawn at its stated error, ``max(rms, spread)``; one within its
  uncertainty carries an arrow down from it (``<=``: it may lie anywhere below), so no picture ranks runs
  inside the uncertainty, and one above it a thin vertical bar over its interval, ``rms ± spread``. A run
  with steps the reference left unsolved is a diamond (``UNSOLVED_MARK``) instead of a circle; both marks are
  named in the legend when drawn.
- **Against time**, one per case: two small panels side by side, the top box's height and the largest
  contact depth, one line per solver at the knob value the summary shows (``compare.chosen``): solid
  where it passed, dashed where it failed, with the rigid rest height and the depth limit as dotted lines.
  A planar case whose scene places boxes at rest gets two more below: how far they drifted sideways and how
  far they turned, with the drift and turn limits dotted.
"""

from __future__ import annotations

import io
import math
from typing import Any

from stackx.bench.compare import case_records, label, measured, pareto
from stackx.bench.palette import colour
from stackx.bench.sweep import Record
from stackx.bench.uncertainty import interval, stated, unsolved, within

AS_EXACT = 1e-12  # m/s: an RMS error below this is the rounding of two ways to the same solve
DEPTH_FLOOR = 0.01  # share of the depth limit below which a depth is drawn at the bottom of its log axis
MARKER = 6.0  # points: the size of a speed plot's marker
RING = 3.5  # points: how much a marker widens for each marker of another solver drawn over it
UNSOLVED_MARK = "D"  # a run whose error holds steps the reference left unsolved
BELOW_MARK = 11  # matplotlib's caret down (base at the point): the end of a '<=' arrow
BELOW = 2.2  # how many times below its uncertainty a '<=' arrow reaches on the log axis


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def _reference(records: list[Record]) -> Record | None:
    """The reference's run, when it was timed and did not blow up."""
    return next((r for r in case_records(records) if r.reference and r.us_per_step is not None and not r.broke),
                None)


def speed_error_png(title: str, records: list[Record]) -> bytes | None:
    """The speed-against-error plot of one case as PNG bytes, or None when no run has both a time and an
    error."""
    return _closed_png(speed_error_figure(title, records))


def _closed_png(fig: Any) -> bytes | None:
    """A figure's PNG bytes, the figure closed; None for no figure."""
    if fig is None:
        return None
    try:
        return _png(fig)
    finally:
        _pyplot().close(fig)


def speed_error_figure(title: str, records: list[Record]) -> Any:
    """The speed-against-error plot of one case as a matplotlib figure (the caller closes it), or None when
    no run has both a time and an error. Each solver's line is labelled with its name; each run's marker is
    a line of one point (``run_marker``) at its stated error, its timing spread (the median repeat) a thin bar
    to its right, its error's uncertainty an arrow down or a bar up and down (``_uncertainty``)."""
    points = measured(records)
    if not points:
        return None
    plt = _pyplot()
    errors = [stated(r) for r in points]
    differing = [e for e in errors if e >= AS_EXACT]
    arrows = [e / BELOW for r, e in zip(points, errors) if within(r.error) and e >= AS_EXACT]  # '<=' ends
    low, high = (min(differing + arrows), max(differing)) if differing else (1e-3, 1e-3)
    as_exact = len(differing) < len(errors)
    band = low / 4  # where the runs as exact as the reference are drawn
    reference = _reference(records)
    xs_all = [float(r.us_per_step) for r in points] + ([reference.us_per_step] if reference else [])  # type: ignore[list-item]
    fig, ax = plt.subplots(figsize=(7.5, 4.6), dpi=100)
    try:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(min(xs_all) / 1.35, max(xs_all) * 1.35)
        ax.set_ylim(band / 2.2 if as_exact else low / 2.2, high * 2.2)
        if as_exact:
            ax.axhspan(band / 2.2, band * 1.8, color="0.93", zorder=0, lw=0)
            ax.text(0.01, band * 1.25, f"error < {AS_EXACT:g} m/s: every step as exact solves it (rounding)",
                    transform=ax.get_yaxis_transform(), fontsize=7, color="0.35", va="bottom")
        fig.subplots_adjust(left=0.12, right=0.97, bottom=0.12, top=0.93)  # fixed: tight_layout costs a second
        markers = []  # (solver, record, x, y as drawn), in drawing order
        for solver in dict.fromkeys(r.solver for r in points):
            recs = sorted((r for r in points if r.solver == solver), key=lambda r: r.value or 0)
            xs = [float(r.us_per_step) for r in recs]  # type: ignore[arg-type]
            shown = [drawn_error(r, band) for r in recs]
            ax.plot(xs, shown, "-", color=colour(solver), lw=1.2, label=solver)
            markers += [(solver, r, x, y) for r, x, y in zip(recs, xs, shown)]
        sizes = marker_sizes(ax.transData.transform([(x, y) for _, _, x, y in markers]),
                             [solver for solver, *_ in markers], fig.dpi)
        for (solver, r, x, y), size in zip(markers, sizes):
            c = colour(solver)
            ax.plot([x], [y], run_marker(r), ms=size, mec=c, mfc=c if r.passed else "white", mew=1.4)
            _uncertainty(ax, r, x, y, c)
            spread = r.timing.get("spread")
            if spread:  # the median repeat: how far another bench may put this run to the right
                ax.plot([x, x * (1 + spread)], [y, y], "-", color=c, lw=0.8, alpha=0.6)
            if r.knob is not None:
                ax.annotate(str(r.value), (x, y), textcoords="offset points", xytext=(4, 3), fontsize=7, color=c)
        front = pareto(points)
        if front:
            fx = [float(r.us_per_step) for r in front]  # type: ignore[arg-type]
            fy = [drawn_error(r, band) for r in front]
            ax.step(fx, fy, where="post", color="0.55", lw=5, alpha=0.35, zorder=0, label="Pareto front (passed)")
            ax.plot(fx, fy, "o", ms=12, mfc="none", mec="0.3", mew=1.0, zorder=0)
        if reference is not None:
            ax.axvline(reference.us_per_step, color=colour(reference.solver), ls="--", lw=1.0,
                       label=f"{reference.solver} (reference, error 0): {reference.us_per_step:.3g} µs/step, "
                             f"{'passed' if reference.passed else 'failed'}")
        _mark_legend(ax, points)
        ax.set_xlabel("microseconds per step (fastest of timed runs; bar: to the median)")
        ax.set_ylabel("RMS velocity error against exact (m/s)")
        ax.set_title(f"{title}: speed against error (filled: passed the case, hollow: failed)", fontsize=10)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7.5, loc="best")
        return fig
    except BaseException:
        plt.close(fig)
        raise


def drawn_error(rec: Record, band: float) -> float:
    """Where a run sits up the speed plot: its stated error (its uncertainty where the error is within it), or
    the as-exact ``band`` below ``AS_EXACT``."""
    e = stated(rec)
    return e if e >= AS_EXACT else band


def run_marker(rec: Record) -> str:
    """A run's marker: a diamond where the reference left steps unsolved, a triangle down where the run is as
    exact as the reference (on the band), a circle otherwise."""
    if unsolved(rec.error):
        return UNSOLVED_MARK
    return "v" if stated(rec) < AS_EXACT else "o"


def _uncertainty(ax: Any, rec: Record, x: float, y: float, c: str) -> None:
    """A run's uncertainty on the speed plot: from an error within it (drawn at it, ``y``), an arrow down
    ending in a caret (``<=``: anywhere below); over an error above it, a thin bar spanning ``rms ± spread``;
    nothing where it is 0."""
    if within(rec.error) and y >= AS_EXACT:
        ax.plot([x, x], [y, y / BELOW], "-", color=c, lw=1.0)
        ax.plot([x], [y / BELOW], marker=BELOW_MARK, ms=6, color=c, ls="none")
    elif not within(rec.error):
        lo, hi = interval(rec)
        if hi > lo and lo > 0.0:
            ax.plot([x, x], [lo, hi], "-", color=c, lw=0.8, alpha=0.6)


def _mark_legend(ax: Any, points: list[Record]) -> None:
    """Legend entries for the marks drawn on this plot only: the diamond of unsolved steps, the '<=' arrow."""
    if any(unsolved(r.error) for r in points):
        ax.plot([], [], UNSOLVED_MARK, color="0.4", mfc="white", ls="none",
                label="diamond: steps the reference left unsolved (error against its best answer)")
    if any(within(r.error) for r in points):
        ax.plot([], [], marker=BELOW_MARK, color="0.4", ls="none",
                label="arrow down: error <= its uncertainty, drawn at it")


def marker_sizes(pixels: Any, solvers: list[str], dpi: float) -> list[float]:
    """The size (points) of each marker, given in drawing order with its centre in pixels: ``MARKER``, plus
    ``RING`` for every marker of another solver drawn later whose centre lies within a marker's width of it.
    A marker drawn over another then leaves a ring of the one below visible (same error, same speed: the
    reader sees both solvers), while markers apart keep the one size."""
    width = MARKER * dpi / 72.0  # a marker's width in pixels
    sizes = []
    for i, (x, y) in enumerate(pixels):
        over = sum(1 for j in range(i + 1, len(solvers)) if solvers[j] != solvers[i]
                   and math.hypot(pixels[j][0] - x, pixels[j][1] - y) < width)
        sizes.append(MARKER + RING * over)
    return sizes


def rest_height(records: list[Record]) -> float | None:
    """The top box's height on a rigid column at the end, from a run that has a series and was not crushed:
    its final top height minus its ``top_rest_error``."""
    for r in case_records(records):
        if r.series is not None and not r.broke and r.series.steps and "top_rest_error" in r.measures:
            return r.series.top[-1] - r.measures["top_rest_error"]
    return None


def trajectories_png(title: str, shown: list[Record], depth_limit: float, rest: float | None,
                     drift_limits: tuple[float, float] | None = None) -> bytes | None:
    """Top height and largest depth against time, one line per record of ``shown`` that has a series, and,
    when the series have drift (planar scenes with boxes placed at rest), two more panels below: the largest
    sideways drift (m) and turn (degrees), with ``drift_limits`` (m, rad) dotted; None when none has a series."""
    drawn = [r for r in shown if r.series is not None and r.series.steps]
    if not drawn:
        return None
    plt = _pyplot()
    floor = DEPTH_FLOOR * depth_limit
    drifts = any(r.series.drift_x is not None for r in drawn)  # type: ignore[union-attr]
    if drifts:
        fig, grid = plt.subplots(2, 2, figsize=(11.5, 6.4), dpi=100, sharex=True)
        (top, deep), (side, turn) = grid
    else:
        fig, (top, deep) = plt.subplots(1, 2, figsize=(11.5, 3.5), dpi=100, sharex=True)
    try:
        for r in drawn:
            s = r.series
            assert s is not None
            t = s.times()
            style = dict(color=colour(r.solver), lw=1.3, ls="-" if r.passed else "--")
            name = f"{label(r.solver, r.knob, r.value)}: {'passed' if r.passed else 'failed'}"
            if r.crushed:
                name += f", crushed at step {r.crushed_at}"
            top.plot(t, s.top, label=name, **style)
            deep.plot(t, [max(d, floor) for d in s.depth], **style)
            if drifts and s.drift_x is not None and s.drift_angle is not None:
                side.plot(t, s.drift_x, **style)
                turn.plot(t, [math.degrees(a) for a in s.drift_angle], **style)
            if r.crushed:
                top.plot(t[-1:], s.top[-1:], "x", color=style["color"], ms=8, mew=2)
                deep.plot(t[-1:], [max(s.depth[-1], floor)], "x", color=style["color"], ms=8, mew=2)
        if rest is not None and math.isfinite(rest):
            top.axhline(rest, color="0.3", ls=":", lw=1, label="rigid rest height")
        _limit(deep, depth_limit, f"depth limit {depth_limit:g} m")
        deep.set_yscale("log")
        deep.set_ylim(bottom=floor / 1.5)
        top.set_title(f"{title}: top box height (m)", fontsize=9)
        deep.set_title(f"{title}: largest contact depth (m; below {floor:g} drawn at the axis)", fontsize=9)
        axes = [top, deep]
        if drifts:
            if drift_limits is not None:
                _limit(side, drift_limits[0], f"drift limit {drift_limits[0]:g} m")
                _limit(turn, math.degrees(drift_limits[1]), f"turn limit {math.degrees(drift_limits[1]):.3g}°")
            side.set_title(f"{title}: largest sideways drift of the boxes placed at rest (m)", fontsize=9)
            turn.set_title(f"{title}: largest turn of the boxes placed at rest (degrees)", fontsize=9)
            for ax in (side, turn):
                ax.set_ylim(bottom=0)
            axes += [side, turn]
        for ax in axes:
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
            ax.tick_params(labelsize=8)
        for ax in axes[-2:]:
            ax.set_xlabel("time (s)")
        fig.legend(fontsize=7, loc="center left", bbox_to_anchor=(0.745, 0.5), frameon=False)
        if drifts:
            fig.subplots_adjust(left=0.06, right=0.73, bottom=0.08, top=0.95, wspace=0.2, hspace=0.22)
        else:
            fig.subplots_adjust(left=0.06, right=0.73, bottom=0.14, top=0.91, wspace=0.2)
        return _png(fig)
    finally:
        plt.close(fig)


def _limit(ax: Any, value: float, text: str) -> None:
    """A dotted horizontal line at a criterion's limit, named at the right end."""
    ax.axhline(value, color="0.3", ls=":", lw=1)
    ax.annotate(text, (0.99, value), xycoords=("axes fraction", "data"), ha="right", va="bottom", fontsize=7,
                color="0.3")


BEYOND = 4.0  # a drift profile's axis spans this many times the limit either way; farther runs sit at its edge


def drift_profile_png(title: str, shown: list[Record], start: Any, rests: list[int],
                      limits: tuple[float, float]) -> bytes | None:
    """``drift_profile_figure`` as PNG bytes; None when it has nothing to draw."""
    return _closed_png(drift_profile_figure(title, shown, start, rests, limits))


def drift_profile_figure(title: str, shown: list[Record], start: Any, rests: list[int],
                         limits: tuple[float, float]) -> Any:
    """Where each box placed at rest ended, against the height it started at: two panels, its sideways drift
    (mm) and its turn (degrees), one line per record of ``shown`` with a final state, the limits dotted. The
    axes span ``BEYOND`` times the limits, so a millimetre's drift or a tenth of a degree shows on a pile of
    forty metres; a box beyond (toppled, slid off) is drawn at the edge as a triangle pointing out. A figure
    the caller closes, or None when no box rests or no run has a final state."""
    drawn = [r for r in shown if r.final is not None]
    if not rests or not drawn:
        return None
    plt = _pyplot()
    idx = list(rests)
    heights = [float(start.y[0, i]) for i in idx]
    fig, (side, turn) = plt.subplots(1, 2, figsize=(11.5, 4.2), dpi=100, sharey=True)
    try:
        for ax, limit, scale, unit in ((side, limits[0], 1e3, "mm"), (turn, limits[1], math.degrees(1.0), "°")):
            edge = BEYOND * limit * scale
            for r in drawn:
                key = "x" if ax is side else "angle"
                moved = [(float(getattr(r.final, key)[0, i]) - float(getattr(start, key)[0, i])) * scale for i in idx]
                inside = [max(-edge, min(edge, m)) for m in moved]
                style = dict(color=colour(r.solver), lw=1.2, ls="-" if r.passed else "--")
                ax.plot(inside, heights, marker="o", ms=3, label=f"{label(r.solver, r.knob, r.value)}: "
                        f"{'passed' if r.passed else 'failed'}" if ax is side else None, **style)
                for sign, mark in ((1, ">"), (-1, "<")):
                    out = [h for m, h in zip(moved, heights) if sign * m > edge]
                    if out:
                        ax.plot([sign * edge] * len(out), out, mark, color=style["color"], ms=7, ls="none")
            for sign in (-1, 1):
                ax.axvline(sign * limit * scale, color="0.3", ls=":", lw=1)
            ax.axvline(0.0, color="0.7", lw=0.8)
            ax.set_xlim(-edge * 1.05, edge * 1.05)
            ax.annotate(f"limit ±{limit * scale:.3g} {unit}", (limit * scale, 1.0), xycoords=("data", "axes fraction"),
                        ha="left", va="top", fontsize=7, color="0.3")
            ax.grid(True, lw=0.3, alpha=0.5)
            ax.tick_params(labelsize=8)
        side.set_xlabel("sideways drift at the end (mm; triangles: beyond the axis)")
        turn.set_xlabel("turn at the end (degrees)")
        side.set_ylabel("height at the start (m)")
        side.set_title(f"{title}: where each box placed at rest ended, from where it started", fontsize=9)
        fig.legend(fontsize=7, loc="center left", bbox_to_anchor=(0.745, 0.5), frameon=False)
        fig.subplots_adjust(left=0.06, right=0.73, bottom=0.13, top=0.92, wspace=0.08)
        return fig
    except BaseException:
        plt.close(fig)
        raise
