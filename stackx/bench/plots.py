"""Speed against error, one PNG per case, drawn with matplotlib's Agg backend (no display, no network).

matplotlib is imported here only, so nothing but ``stackx bench`` pays for it. Log-log axes: microseconds
per step across, RMS velocity error against the exact solver up; one line per solver through its knob
values (labelled), filled markers where the run passed the case and hollow where it failed, and the Pareto
front (no other run both faster and more accurate) drawn as a grey band with ringed points.
"""

from __future__ import annotations

import io

from stackx.bench.compare import measured, pareto
from stackx.bench.sweep import Record

FLOOR = 1e-15  # errors below this (the exact solver's own rounding) are drawn at it on the log axis


def speed_error_png(title: str, records: list[Record]) -> bytes | None:
    """The plot of one case as PNG bytes, or None when no run has both a time and an error."""
    points = measured(records)
    if not points:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0), dpi=100)
    try:
        solvers = list(dict.fromkeys(r.solver for r in points))
        colours = plt.get_cmap("tab10")
        for i, solver in enumerate(solvers):
            recs = sorted((r for r in points if r.solver == solver), key=lambda r: r.value or 0)
            xs = [r.us_per_step for r in recs]
            ys = [max(r.error["rms"], FLOOR) for r in recs]  # type: ignore[type-var]
            colour = colours(i % 10)
            ax.plot(xs, ys, "-", color=colour, lw=1.2, label=solver)
            for r, x, y in zip(recs, xs, ys):
                ax.plot([x], [y], "o", ms=6, mec=colour, mfc=colour if r.passed else "white", mew=1.4)
                if r.knob is not None:
                    ax.annotate(str(r.value), (x, y), textcoords="offset points", xytext=(4, 3), fontsize=7,
                                color=colour)
        front = pareto(points)
        fx = [r.us_per_step for r in front]
        fy = [max(r.error["rms"], FLOOR) for r in front]  # type: ignore[type-var]
        ax.step(fx, fy, where="post", color="0.55", lw=5, alpha=0.35, zorder=0, label="Pareto front")
        ax.plot(fx, fy, "o", ms=12, mfc="none", mec="0.3", mew=1.0, zorder=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("microseconds per step (median of timed runs)")
        ax.set_ylabel(f"RMS velocity error against exact (m/s; < {FLOOR:g} drawn at {FLOOR:g})")
        ax.set_title(f"{title}: speed against error (filled: passed the case, hollow: failed)", fontsize=10)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, loc="best")
        fig.subplots_adjust(left=0.12, right=0.97, bottom=0.11, top=0.93)  # fixed: tight_layout costs a second
        buf = io.BytesIO()
        fig.savefig(buf, format="png", metadata={"Software": None})
        return buf.getvalue()
    finally:
        plt.close(fig)
