"""One colour per solver, keyed by its name, for every plot and table of a bench report.

A solver keeps its colour from plot to plot and from report to report, so a reader who has learnt that the
lab solver is red need not read a legend again. The built-in solvers have colours of their own (the lab
solver red, the reference near black, the others the remaining colours of matplotlib's ``tab10`` and, for the
planar solvers with no column counterpart and the engines, ``OWN``); any other
solver (a plugin) gets one of a second set, picked by a hash of its name, so it too keeps its colour
everywhere (two plugins may share one). A planar solver named after a column one (``planar-pgs``) has that
solver's hue, darker (``SHADE``): the lab's rules are red on either model, and no two built-ins share a colour.
"""

from __future__ import annotations

import hashlib

BUILT_IN = {
    "pgs": "#d62728",
    "warm-start": "#1f77b4",
    "baumgarte": "#8c564b",
    "split-impulse": "#ff7f0e",
    "ngs": "#2ca02c",
    "soft-step": "#9467bd",
    "xpbd": "#17becf",
    "jacobi": "#bcbd22",
    "exact": "#222222",
    "avbd": "#d6616b",
}
OWN = {  # built-in solvers with no column counterpart: the planar-only ones and the engines
    "planar-pgs-soft": "#8ca252",
    "planar-tgs-soft": "#7b4173",
    "planar-tgs-sticky": "#8c6d31",
    "planar-tgs-ngs": "#5254a3",
    "planar-shock": "#e7ba52",
    "pymunk": "#bd9e39",
    "box2d": "#a55194",
    "box2d-v3": "#6baed6",
    "mujoco": "#9c9ede",
}
PLANAR = "planar-"  # the planar solvers' prefix: planar-pgs is the lab's rules on the planar model
SHADE = 0.6  # a planar solver's colour: its column counterpart's, each channel times this
OTHERS = ("#e377c2", "#7f7f7f", "#6b6ecf", "#b5651d", "#637939", "#ad494a", "#3182bd", "#e6550d", "#31a354",
          "#756bb1")


def colour(solver: str) -> str:
    """The solver's colour as ``#rrggbb``: its own for a built-in, its counterpart's darker for a planar one,
    else one of ``OTHERS`` by a hash of the name (a hash of the bytes, not Python's ``hash``, which changes from
    process to process)."""
    if solver in BUILT_IN:
        return BUILT_IN[solver]
    if solver in OWN:
        return OWN[solver]
    if solver.startswith(PLANAR) and solver[len(PLANAR):] in BUILT_IN:
        rgb = bytes.fromhex(BUILT_IN[solver[len(PLANAR):]][1:])
        return "#" + bytes(int(c * SHADE) for c in rgb).hex()
    digest = hashlib.sha256(solver.encode()).digest()
    return OTHERS[int.from_bytes(digest[:4], "big") % len(OTHERS)]
