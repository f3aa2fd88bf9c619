"""Attacks by a config: small files that ask for unbounded work, or that turn into code.

The contract (docs/configs.md, docs/outputs.md): every renderer's work is bounded at load from the config's
shape (``compare`` counts runs x frames against ``max_frames``, named runs count against ``max_runs`` and are
checked in linear time, shapes are clipped to the canvas before they are walked); code runs only from where the
user said (plugins from the config's own folder, never an ancestor; no output path ending in ``.py`` or landing
in a plugin folder; keyvalue keys are identifiers); and every error is one readable line.
"""

from __future__ import annotations

import os
from pathlib import Path

from benchmarks.attacks.kit import CONFIGS, Finished, Outcome, manifest_problems, stackx, write_config

QUICK_S = 2.0
"""``validate`` must refuse an exploding config within this much processor time (a fresh process, imports
included: about 1 s). Processor time, not wall time: a loaded machine stretches the one, not the other."""
BOUND_MB = 300
"""...holding at most this much (about 60 MB for a plain config)."""
NAMED_S = (10.0, 30.0)
"""20,000 named runs (twice ``max_runs``) refused, and 10,000 (the limit) validated, within these processor
seconds: the text alone is 600 KB of YAML to read; checking the names in quadratic time took minutes."""
LINE_CHARS = 500
"""The longest error line a refusal may print: the file, the key and what is allowed, a long value cut."""

STEPS_BASE = """\
description: one box
scene:
  name: column
  boxes:
    - {y: 1.5, v: 0.0, half_height: 0.5, mass: 1.0}
solver:
  name: pgs
  iterations: 10
gravity: -9.8
dt: 1/60
"""


def _sweep(keys: int, values: int, count: int) -> str:
    """``values``**``keys`` runs (a sweep grid) each drawn ``count`` times by ``compare``: a few hundred bytes,
    every value within its limit."""
    grid = {"solver.iterations": [1 + k for k in range(values)],
            "gravity": [-9.0 - k / 10 for k in range(values)],
            "steps": [count + k for k in range(values)],
            "solver.correction.percent": [0.1 + k / 100 for k in range(values)]}
    chosen = list(grid.items())[:keys]
    name = "_".join(f"{{{key}}}" for key, _ in chosen)
    lines = [f"    {key}: {values!r}" for key, values in chosen]
    return (STEPS_BASE.replace("iterations: 10", "iterations: 10\n  correction: {slop: 0.01, percent: 0.2}")
            + f"steps: {count}\nsweep:\n  name: r{name}\n  grid:\n" + "\n".join(lines)
            + f"\noutputs:\n  - render: compare\n    every: 1\n    count: {count}\n")


def _took(done: Finished) -> str:
    """Processor time (what the bounds judge) and wall time, for a figure."""
    return f"{done.cpu_s * 1000:.0f} ms cpu ({done.seconds * 1000:.0f} ms wall)"


def _bounded(done: Finished) -> str:
    """'' when ``done`` is a one-line refusal within ``QUICK_S`` and ``BOUND_MB``; else what is wrong."""
    if done.stopped:
        return done.stopped
    if not done.one_line_refusal():
        return f"not refused: {done.brief()} {done.stderr.strip()[-120:]}"
    if done.cpu_s > QUICK_S:
        return f"took {done.cpu_s:.1f} s of processor time"
    if done.peak_mb > BOUND_MB:
        return f"took {done.peak_mb:.0f} MB"
    return ""


def compare_explosion(root: Path) -> Outcome:
    """``compare`` over 10,000 runs x 10,000 frames, and over 100 runs x 10,000 frames (a million pictures):
    ``validate`` refuses both at once."""
    cases = {"10,000 x 10,000": _sweep(4, 10, 10_000), "100 x 10,000": _sweep(2, 10, 10_000)}
    figures, wrongs = [], []
    for label, text in cases.items():
        config = write_config(root / f"c{len(figures)}.yaml", text)
        done = stackx("validate", config, cwd=root, timeout=60, memory_mb=1024)
        figures.append(f"{label}: {done.brief()} {_took(done)} {done.peak_mb:.0f} MB")
        wrong = _bounded(done)
        if wrong:
            wrongs.append(f"{label}: {wrong}")
    return Outcome(not wrongs, ", ".join(figures) + "".join(f"; {w}" for w in wrongs))


DRAWING = """\
description: shapes far off a small canvas
outputs:
  - render: drawing
    path: far.png
    width: 64
    height: 64
    shapes:
      - line: {from: [0, 0], to: [1000000000000000000, 1000000000000000000], rgb: [255, 255, 255]}
      - line: {from: [-1000000000000000000, 32], to: [1000000000000000000, 33], rgb: [255, 0, 0]}
      - rect: {from: [-1000000000000000000, -1000000000000000000], to: [1000000000000000000, 3], rgb: [0, 0, 255]}
"""
DRAWING_S = 10.0


def far_shapes(root: Path) -> Outcome:
    """The ``drawing`` renderer's line to (1e18, 1e18), and a rectangle as wide, on a 64 x 64 canvas: the run
    finishes (the shapes clipped before they are walked) and writes the picture."""
    config = write_config(root / "far.yaml", DRAWING)
    out = root / "out"
    done = stackx("run", config, "--out", out, "-q", cwd=root, timeout=3 * DRAWING_S)
    if done.code == 0:
        problems = manifest_problems(out) + ([] if (out / "far.png").is_file() else ["far.png missing"])
        wrong = "; ".join(problems)
    else:
        wrong = f"{done.brief()} {done.stderr.strip()[-120:]}"
    if not wrong and done.cpu_s > DRAWING_S:
        wrong = f"over {DRAWING_S:g} s of processor time"
    return Outcome(not wrong, f"{done.brief()} in {_took(done)}" + (f"; {wrong}" if wrong else ""))


def _named(n: int) -> str:
    lines = [f"  r{i:05d}: {{gravity: {-9.0 - (i % 100) / 100}}}" for i in range(n)]
    return STEPS_BASE + "steps: 10\nruns:\n" + "\n".join(lines) + "\n"


def named_runs(root: Path) -> Outcome:
    """20,000 named runs (over ``max_runs``): refused at once; 10,000 (the limit): checked in linear time."""
    over = stackx("validate", write_config(root / "over.yaml", _named(20_000)), cwd=root, timeout=3 * NAMED_S[0],
                  memory_mb=1024)
    at = stackx("validate", write_config(root / "at.yaml", _named(10_000)), cwd=root, timeout=2 * NAMED_S[1],
                memory_mb=1024)
    wrongs = []
    if over.stopped or not over.one_line_refusal() or over.cpu_s > NAMED_S[0]:
        wrongs.append(f"20,000 not refused within {NAMED_S[0]:g} s")
    if at.stopped or at.code != 0 or at.cpu_s > NAMED_S[1]:
        wrongs.append(f"10,000 not validated within {NAMED_S[1]:g} s {at.stderr.strip()[-120:]}")
    figure = (f"20,000 runs: {over.brief()} {_took(over)}; 10,000 runs: {at.brief()} {_took(at)} "
              f"{at.peak_mb:.0f} MB")
    return Outcome(not wrongs, figure + "".join(f"; {w}" for w in wrongs))


PLANTED = """\
from pathlib import Path
Path({marker!r}).write_text("imported")
"""


def ancestor_plugins(root: Path) -> Outcome:
    """A ``plugins/`` folder planted in a shared folder three levels above a config: neither ``validate`` nor
    ``run`` imports it."""
    shared = root / "shared"
    marker = root / "IMPORTED"
    write_config(shared / "plugins" / "planted.py", PLANTED.format(marker=str(marker)))
    config = shared / "a" / "b" / "c" / "03-sink.yaml"
    write_config(config, (CONFIGS / "03-sink.yaml").read_text())
    codes = []
    for args in (("validate", config), ("run", config, "--out", root / "out", "-q")):
        done = stackx(*args, cwd=root)
        codes.append(done.code)
        if marker.exists():
            return Outcome(False, f"imported by {args[0]} ({done.brief()})")
    ok = codes == [0, 0]
    return Outcome(ok, f"not imported by validate or run (exits {codes})")


INJECTION = """\
description: a note for the next command
scene:
  name: column
  boxes:
    - {{y: 1.5, v: 0.0, half_height: 0.5, mass: 1.0}}
solver: {{name: pgs, iterations: 10}}
gravity: -9.8
dt: 1/60
steps: 60
outputs:
  - sink: keyvalue
    path: {path}
    values:
      {key!r}: depth[0]
"""


def keyvalue_code(root: Path) -> Outcome:
    """A keyvalue sink writing ``plugins/zz_notes.py`` with the key ``import os; os.system('touch PWNED');
    depth``, in the layout ``stackx run DIR/configs --out DIR``: refused (as are a ``.py`` path with a plain key
    and a code key in a ``.txt``), and the next ``validate`` runs nothing."""
    marker = root / "PWNED"
    code = f"import os; os.system('touch {marker}'); depth"
    cases = {"plugins/zz_notes.py + code key": ("plugins/zz_notes.py", code),
             "notes.py": ("notes.py", "depth"), "code key in notes.txt": ("notes.txt", code)}
    figures, wrongs = [], []
    for i, (label, (path, key)) in enumerate(cases.items()):
        lab = root / f"lab{i}"
        config = write_config(lab / "configs" / "notes.yaml", INJECTION.format(path=path, key=key))
        ran = stackx("run", lab / "configs", "--out", lab, "-q", cwd=root)
        after = stackx("validate", lab / "configs", cwd=root)
        figures.append(f"{label}: {ran.brief()}")
        if not ran.one_line_refusal():
            wrongs.append(f"{label} not refused ({ran.brief()})")
        if marker.exists():
            wrongs.append(f"{label}: the code ran (validate {after.brief()})")
            marker.unlink()
        del config
    return Outcome(not wrongs, ", ".join(figures) + "".join(f"; {w}" for w in wrongs))


def long_lines(root: Path) -> Outcome:
    """Refusals whose values are huge: a compare naming an unknown run among 10,000 (the error lists them), a
    5,000-character key, ``--out`` a 5,000-character path and ``--out`` a link loop: each one short line, exit 2,
    no traceback."""
    compare = _sweep(4, 10, 2).replace("count: 2\n", "count: 2\n    runs: [nosuch]\n")
    loop = root / "loop"
    os.symlink(loop, loop)
    sink = CONFIGS / "03-sink.yaml"
    cases = {"unknown run among 10,000": ("validate", write_config(root / "compare.yaml", compare)),
             "5,000-character key": ("validate", write_config(root / "key.yaml", (sink.read_text()
                                                                                  + "k" * 5000 + ": 1\n"))),
             "--out 5,000 characters": ("run", sink, "--out", root / (("o" * 200 + "/") * 25), "-q"),
             "--out a link loop": ("run", sink, "--out", loop, "-q")}
    figures, wrongs = [], []
    for label, args in cases.items():
        done = stackx(*args, cwd=root, timeout=120)
        longest = max((len(ln) for ln in done.stderr.splitlines()), default=0)
        figures.append(f"{label}: {done.brief()} {longest} chars")
        if not done.one_line_refusal() or longest > LINE_CHARS:
            wrongs.append(f"{label}: {done.brief()}{', a traceback' if done.traceback else ''}, {longest} chars")
    return Outcome(not wrongs, ", ".join(figures) + "".join(f"; {w}" for w in wrongs))
