"""The speed benchmark: stackx against a plain-Python and a C transcription of the same algorithm.

Sections, each timed side by side in one run (implementations take turns, medians compared):

- **scene 06**: the lab's five-box stack, 900 steps, the lab solver;
- **tall columns** of 20, 100, 1,000 and 10,000 resting boxes (the hard cases' scene), stepped by a solver
  that holds them (``--tall-solver``; by default the first of warm-start and exact that holds tall-1000) and
  by the lab solver, with the fitted exponent of cost against boxes;
- **sweep**: 10,000 variants of scene 06 (slop x percent x iterations) as one batch over every core, against
  the C transcription stepping them one after another on one core;
- **commands**: wall time of ``stackx run configs/`` and ``stackx --help`` (compiled code cached);
- **compile**: the first run's compile cost, measured with an empty cache, apart from everything else.

Every section also checks that the implementations end on the same heights (max |dy|; 0 is bit-identical).
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console
from rich.table import Table

from benchmarks.native import Native, build
from benchmarks.subjects import TRANSCRIBED, Subject, largest_difference, write_config
from benchmarks.timing import Sample, fitted_exponent, interleaved
from stackx import kernel
from stackx.config.experiment import load
from stackx.registry import solvers

REPO = Path(__file__).resolve().parents[1]
LAB = REPO / "configs"
SCENE_06 = LAB / "06-stack.yaml"
TALL_SIZES = (20, 100, 1000, 10_000)
SWEEP_GRID = {"solver.correction.slop": [round(0.002 * i, 3) for i in range(25)],
              "solver.correction.percent": [round(0.05 * (i + 1), 2) for i in range(20)],
              "solver.iterations": list(range(5, 25))}  # 25 x 20 x 20 = 10,000 variants
BUSY = 0.25  # cores kept busy by other processes above which a section's figures are flagged
PYTHON_SWEEP_SHARE = 100  # the plain-Python transcription steps every 100th variant of the sweep
SHORT_RUNS = 10  # scene-06 runs per timed sample of stackx and C
LAB_SLOP = 0.01  # the hard cases judge depth against 2 x this
TALL_CANDIDATES = ("warm-start", "exact")  # solvers meant to hold tall columns, in order of preference

console = Console()


@dataclass
class Context:
    """What every section needs: the C library (or why there is none), a scratch folder, the options."""

    native: Native | str
    tmp: Path
    quick: bool
    tall_solver: dict[str, Any]
    targets: list[dict[str, Any]] = field(default_factory=list)

    def repeats(self, full: int) -> int:
        return max(2, full // 4) if self.quick else full

    def target(self, what: str, goal: str, value: float | None, met: bool | None, unit: str = "") -> None:
        self.targets.append({"target": what, "goal": goal, "measured": value, "unit": unit, "met": met})


def speedup(slower: Sample | None, faster: Sample | None) -> float | None:
    """Time per unit of ``slower`` over that of ``faster`` (median against median): how many times faster."""
    return None if slower is None or faster is None else slower.per_unit / faster.per_unit


def _fmt(x: float | None, digits: int = 3) -> str:
    return "-" if x is None else f"{x:.{digits}g}"


# ------------------------------------------------------------------------------------------- scene 06


def scene_06(ctx: Context) -> dict[str, Any]:
    """The lab's scene and solver: per-step time of every implementation, and stackx's runner end to end."""
    steps = 900
    sub = Subject(load(str(SCENE_06)))
    first = _first_call(sub)
    runs = SHORT_RUNS  # runs of the scene per timed sample for the fast ones: a sample of one run is 0.3 ms
    setups: dict[str, tuple[Callable[[], Any], int]] = {
        "stackx": (lambda: chained([sub.stackx(steps)[0] for _ in range(runs)]), runs * steps),
        "stackx plain path": (lambda: sub.stackx(steps, compiled=False)[0], steps),
        "python": (lambda: sub.python(steps)[0], steps),
    }
    if isinstance(ctx.native, Native):
        native = ctx.native
        setups["c"] = (lambda: chained([sub.c(native, steps)[0] for _ in range(runs)]), runs * steps)
    samples = interleaved(setups, ctx.repeats(30))
    samples["stackx runner"] = _runner_per_step(ctx, steps)

    agree = _agreement(sub, ctx, steps)
    c = samples.get("c")
    table = Table(title=f"scene 06 (configs/06-stack.yaml): 5 boxes, {steps} steps, pgs 15 iterations")
    for col in ("implementation", "µs/step (median)", "µs/step (min)", "python ÷ this", "this ÷ c"):
        table.add_column(col, justify="left" if col == "implementation" else "right")
    for name, s in samples.items():
        table.add_row(name, _fmt(s.per_unit * 1e6), _fmt(min(s.seconds) / s.units * 1e6),
                      _fmt(speedup(samples["python"], s)), _fmt(speedup(s, c)))
    console.print(table)
    console.print(f"  stackx runner: run_experiment() of the config compiled, recording its 12 frames and motion "
                  f"window, per step; first compiled call in this process {first:.3f} s (cache load or compile)")
    ratio = speedup(samples["stackx"], c)
    ctx.target("scene 06: stackx per step vs C", "<= 2x", ratio, None if ratio is None else ratio <= 2.0, "x")
    return {"steps": steps, "us_per_step": {k: s.as_dict() for k, s in samples.items()},
            "stackx_over_c": ratio, "python_over_stackx": speedup(samples["python"], samples["stackx"]),
            "first_compiled_call_s": first, "agreement_max_abs_dy": agree}


def chained(runs: list[Callable[[], None]]) -> Callable[[], None]:
    """One timed sample made of several prepared runs, one after another."""

    def run_all() -> None:
        for run in runs:
            run()

    return run_all


def _first_call(sub: Subject) -> float:
    run, _ = sub.stackx(1)
    t0 = time.perf_counter()
    run()
    return time.perf_counter() - t0


def _runner_per_step(ctx: Context, steps: int) -> Sample:
    """``run_experiment`` of the 06 config, compiled: stepping plus recording plus measures, per step."""
    from stackx.run.runner import run_experiment

    spec = load(str(SCENE_06))
    sample = Sample(steps)
    before = os.environ.get("STACKX_JIT")
    os.environ["STACKX_JIT"] = "1"
    try:
        run_experiment(spec)
        for _ in range(ctx.repeats(20)):
            t0 = time.perf_counter()
            run_experiment(spec)
            sample.seconds.append(time.perf_counter() - t0)
    finally:
        if before is None:
            os.environ.pop("STACKX_JIT", None)
        else:
            os.environ["STACKX_JIT"] = before
    return sample


def _agreement(sub: Subject, ctx: Context, steps: int, rows: list[int] | None = None) -> dict[str, float]:
    """Largest height difference of every implementation against compiled stackx after ``steps`` steps."""
    run, state = sub.stackx(steps)
    run()
    ref = state.y if rows is None else state.y[rows]
    out = {}
    if rows is None:
        run_plain, plain_state = sub.stackx(steps, compiled=False)
        run_plain()
        out["stackx plain path"] = largest_difference(ref, plain_state.y)
    run_py, ys = sub.python(steps, rows)
    run_py()
    out["python"] = largest_difference(ref, ys)
    if isinstance(ctx.native, Native):
        run_c, cy = sub.c(ctx.native, steps)
        run_c()
        out["c"] = largest_difference(state.y, cy)
    console.print("  agreement with compiled stackx (max |dy|, 0 = bit-identical): "
                  + ", ".join(f"{k} {v:.3g}" for k, v in out.items()))
    return out


# ------------------------------------------------------------------------------------------- tall columns


def tall_doc(count: int, solver: dict[str, Any]) -> dict[str, Any]:
    """The hard cases' tall column: ``count`` equal boxes 1 mm apart, resting; 600 steps for 20, else 1200."""
    return {"description": f"tall-{count}", "scene": {"name": "column", "stack": {"count": count, "y0": 0.501,
                                                                                  "spacing": 1.0}},
            "solver": solver, "dt": "1/60", "steps": 600 if count <= 20 else 1200}


def tall(ctx: Context) -> dict[str, Any]:
    """Cost per step against boxes for the holding solver and the lab solver; ratios against C."""
    sizes = TALL_SIZES[:3] if ctx.quick else TALL_SIZES
    name = ctx.tall_solver["name"]
    lab = {"name": "pgs", "iterations": 15, "correction": {"slop": 0.01, "percent": 0.2}}
    rows: dict[int, dict[str, Any]] = {}
    for n in sizes:
        hold = Subject(write_config(ctx.tmp, f"tall-{n}-hold", tall_doc(n, ctx.tall_solver)))
        pgs = Subject(write_config(ctx.tmp, f"tall-{n}-pgs", tall_doc(n, lab)))
        steps = hold.spec.runs[0].steps
        _first_call(hold)
        _first_call(pgs)
        setups: dict[str, tuple[Callable[[], Any], int]] = {f"stackx {name}": (lambda h=hold: h.stackx(steps)[0], steps)}
        if name != "pgs":
            setups["stackx pgs"] = (lambda p=pgs: p.stackx(steps)[0], steps)
        if isinstance(ctx.native, Native):
            native = ctx.native
            if name in TRANSCRIBED and name != "pgs":
                setups[f"c {name}"] = (lambda h=hold: h.c(native, steps)[0], steps)
            setups["c pgs"] = (lambda h=hold: h.c_lab(native, steps), steps)
        samples = interleaved(setups, ctx.repeats({20: 30, 100: 20, 1000: 6}.get(n, 3)))
        py_steps = max(2, min(steps, 200_000 // n))
        if name in TRANSCRIBED:
            samples[f"python {name}"] = interleaved({"p": (lambda h=hold: h.python(py_steps)[0], py_steps)},
                                                    1 if n >= 10_000 else 3)["p"]
        held, depth, reach = holds(hold)
        rows[n] = {"steps": steps, "python_steps": py_steps,
                   "us_per_step": {k: s.as_dict() for k, s in samples.items()},
                   "final_max_depth": depth, "reach": reach, "holds": held,
                   "agreement_max_abs_dy": _tall_agreement(hold, ctx, min(steps, py_steps))}
        rows[n]["samples"] = samples
    out = _tall_table(ctx, name, sizes, rows)
    for n in sizes:
        rows[n].pop("samples")
    return {"solver": ctx.tall_solver, "sizes": list(sizes), "by_size": rows, **out}


def _tall_agreement(sub: Subject, ctx: Context, steps: int) -> dict[str, float]:
    if sub.solver not in TRANSCRIBED:
        return {}
    run, state = sub.stackx(steps)
    run()
    run_py, ys = sub.python(steps)
    run_py()
    out = {"python": largest_difference(state.y, ys)}
    if isinstance(ctx.native, Native):
        run_c, cy = sub.c(ctx.native, steps)
        run_c()
        out["c"] = largest_difference(state.y, cy)
    return out


def _tall_table(ctx: Context, name: str, sizes: tuple[int, ...], rows: dict[int, dict[str, Any]]) -> dict[str, Any]:
    impls = list(rows[sizes[0]]["samples"])
    table = Table(title=f"tall columns: µs per step (median); holding solver {ctx.tall_solver}")
    table.add_column("implementation")
    for n in sizes:
        table.add_column(f"{n:,} boxes", justify="right")
    table.add_column("fitted exponent", justify="right")
    exponents = {}
    for impl in impls:
        costs = [rows[n]["samples"][impl].per_unit for n in sizes if impl in rows[n]["samples"]]
        exponents[impl] = fitted_exponent(list(sizes), costs) if len(costs) == len(sizes) else None
        table.add_row(impl, *[_fmt(c * 1e6) for c in costs], _fmt(exponents[impl]))
    hold, c_lab, c_same = f"stackx {name}", "c pgs", f"c {name}" if name != "pgs" else "c pgs"
    ratios: dict[str, dict[int, float | None]] = {"stackx_hold_over_c_lab": {}, "stackx_hold_over_c_same": {},
                                                  "python_over_stackx": {}}
    for n in sizes:
        s = rows[n]["samples"]
        ratios["stackx_hold_over_c_lab"][n] = speedup(s[hold], s.get(c_lab)) if c_lab in s else None
        ratios["stackx_hold_over_c_same"][n] = speedup(s[hold], s.get(c_same)) if c_same in s else None
        ratios["python_over_stackx"][n] = speedup(s.get(f"python {name}"), s[hold])
    for key, label in (("stackx_hold_over_c_lab", f"stackx {name} ÷ c pgs (time)"),
                       ("stackx_hold_over_c_same", f"stackx {name} ÷ c {name} (time)"),
                       ("python_over_stackx", f"python {name} ÷ stackx {name} (time)")):
        table.add_row(label, *[_fmt(ratios[key][n]) for n in sizes], "")
    table.add_row("holds (final depth <= 0.02, reach <= 1)", *["yes" if rows[n]["holds"] else "NO" for n in sizes], "")
    console.print(table)
    console.print("  python columns time the first " + ", ".join(f"{rows[n]['python_steps']}" for n in sizes)
                  + " steps; agreement (max |dy|) " + "; ".join(f"{n}: {rows[n]['agreement_max_abs_dy']}" for n in sizes))
    e = exponents[hold]
    ctx.target(f"tall columns: fitted exponent of stackx {name}", "about 1 (linear)", e,
               None if e is None else 0.85 <= e <= 1.15)
    r1000 = ratios["stackx_hold_over_c_lab"].get(1000)
    holds = rows[1000]["holds"] if 1000 in rows else None
    ctx.target(f"tall-1000: stackx {name} per step vs C lab step", "<= 2x", r1000,
               None if r1000 is None else r1000 <= 2.0 and bool(holds), "x" + ("" if holds else f" ({name} does not hold)"))
    return {"fitted_exponent": exponents, "ratios": ratios}


# ------------------------------------------------------------------------------------------- sweep


def sweep(ctx: Context) -> dict[str, Any]:
    """10,000 variants of scene 06 as one batch: throughput against the C transcription on one core."""
    from stackx.run.runner import run_experiment

    doc = yaml.safe_load(SCENE_06.read_text())
    grid = {k: v[: max(2, len(v) // 3)] for k, v in SWEEP_GRID.items()} if ctx.quick else SWEEP_GRID
    doc.update(outputs=[], sweep={"name": "v{index}", "grid": grid})
    t0 = time.perf_counter()
    spec = write_config(ctx.tmp, "sweep-06", doc)
    load_s = time.perf_counter() - t0
    sub = Subject(spec)
    rows, steps = sub.rows, spec.runs[0].steps
    _first_call(sub)
    setups: dict[str, tuple[Callable[[], Any], int]] = {"stackx": (lambda: sub.stackx(steps)[0], rows * steps)}
    if isinstance(ctx.native, Native):
        native = ctx.native
        setups["c (one core)"] = (lambda: sub.c(native, steps)[0], rows * steps)
    samples = interleaved(setups, ctx.repeats(3) if not ctx.quick else 2)
    picked = list(range(0, rows, PYTHON_SWEEP_SHARE))
    samples["python"] = interleaved({"p": (lambda: sub.python(steps, picked)[0], len(picked) * steps)}, 1)["p"]

    t0 = time.perf_counter()
    result = run_experiment(spec)
    runner_s = time.perf_counter() - t0
    stepping_s = sum(r.wall_seconds for r in result.runs)
    agree = _agreement(sub, ctx, steps, picked)

    thr = {k: 1.0 / s.per_unit for k, s in samples.items()}
    thr["stackx runner (stepping)"] = rows * steps / stepping_s
    thr["stackx runner (end to end)"] = rows * steps / runner_s
    c = thr.get("c (one core)")
    table = Table(title=f"sweep: {rows:,} variants of scene 06 x {steps} steps "
                        f"(slop x percent x iterations), {os.cpu_count()} cores")
    for col in ("implementation", "scene-steps/s", "÷ c one core", "÷ python"):
        table.add_column(col, justify="left" if col == "implementation" else "right")
    for k, v in thr.items():
        table.add_row(k, f"{v:,.0f}", _fmt(v / c if c else None), _fmt(v / thr["python"]))
    console.print(table)
    console.print(f"  config load (validating {rows:,} variants) {load_s:.2f} s; run_experiment {runner_s:.2f} s "
                  f"of which stepping {stepping_s:.2f} s; python timed on every {PYTHON_SWEEP_SHARE}th variant")
    ratio = None if c is None else thr["stackx"] / c
    ctx.target(f"sweep of {rows:,}: stackx throughput vs C single-thread", ">= 1.5x", ratio,
               None if ratio is None else ratio >= 1.5, "x")
    return {"variants": rows, "steps": steps, "grid": grid, "threads": _threads(),
            "scene_steps_per_s": thr, "samples": {k: s.as_dict(1e9) for k, s in samples.items()},
            "stackx_over_c_single_thread": ratio, "config_load_s": load_s, "run_experiment_s": runner_s,
            "runner_stepping_s": stepping_s, "agreement_max_abs_dy": agree}


def _threads() -> int | None:
    try:
        import numba

        return int(numba.get_num_threads())
    except ImportError:
        return None


# ------------------------------------------------------------------------------------------- commands


def stackx_command() -> list[str]:
    """How a user runs stackx here: the console script beside this Python, else ``python -m stackx``."""
    script = Path(sys.executable).with_name("stackx")
    return [str(script)] if script.exists() else [sys.executable, "-m", "stackx"]


def wall(command: list[str], repeats: int, env: dict[str, str] | None = None, warm: bool = True) -> list[float]:
    """Wall seconds of a command, ``repeats`` times (after one untimed run when ``warm``)."""
    full_env = {**os.environ, **(env or {})}
    times = []
    for i in range(repeats + (1 if warm else 0)):
        t0 = time.perf_counter()
        subprocess.run(command, check=True, cwd=REPO, env=full_env, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        if i or not warm:
            times.append(time.perf_counter() - t0)
    return times


def commands(ctx: Context) -> dict[str, Any]:
    """Wall time of the whole lab and of ``--help`` (compiled code cached)."""
    exe = stackx_command()
    out = str(ctx.tmp / "lab-out")
    cases = {
        "stackx --help": ([*exe, "--help"], {}, 9),
        "stackx run configs/": ([*exe, "run", "configs/", "--out", out, "-q"], {}, 5),
        "STACKX_JIT=1 stackx run configs/": ([*exe, "run", "configs/", "--out", out, "-q"], {"STACKX_JIT": "1"}, 5),
        "STACKX_JIT=0 stackx run configs/": ([*exe, "run", "configs/", "--out", out, "-q"], {"STACKX_JIT": "0"}, 3),
    }
    res = {}
    table = Table(title=f"commands, wall seconds ({' '.join(exe)}; compiled code cached)")
    for col in ("command", "median", "min"):
        table.add_column(col, justify="left" if col == "command" else "right")
    for label, (cmd, env, n) in cases.items():
        times = wall(cmd, ctx.repeats(n), env)
        res[label] = {"median_s": statistics.median(times), "min_s": min(times), "seconds": times,
                      "command": " ".join(cmd)}
        table.add_row(label, f"{statistics.median(times):.3f}", f"{min(times):.3f}")
    console.print(table)
    lab, lab1, helps = (res[k]["median_s"] for k in ("stackx run configs/", "STACKX_JIT=1 stackx run configs/",
                                                     "stackx --help"))
    ctx.target("stackx run configs/ (cached)", "< 1.5 s", lab, lab < 1.5, "s")
    ctx.target("STACKX_JIT=1 stackx run configs/ (cached)", "< 1.5 s", lab1, lab1 < 1.5, "s")
    ctx.target("stackx --help", "< 0.25 s", helps, helps < 0.25, "s")
    return res


def compile_cost(ctx: Context) -> dict[str, Any]:
    """First runs with an empty cache, next to the same runs cached: what compiling costs, and who pays it."""
    exe = stackx_command()
    name = ctx.tall_solver["name"]
    write_config(ctx.tmp, "compile-tall-100", tall_doc(100, ctx.tall_solver))
    runs = {
        "06-stack, compiled": ([*exe, "run", str(SCENE_06)], {"STACKX_JIT": "1"}),
        "06-stack, default (auto)": ([*exe, "run", str(SCENE_06)], {}),
        "lab (configs/), compiled": ([*exe, "run", str(LAB)], {"STACKX_JIT": "1"}),
        "lab (configs/), default (auto)": ([*exe, "run", str(LAB)], {}),
        f"tall-100 {name}, default (auto)": ([*exe, "run", str(ctx.tmp / "compile-tall-100.yaml")], {}),
    }
    res = {}
    table = Table(title="first run with an empty compile cache against the same run cached (wall seconds)")
    for col in ("run", "empty cache", "cached (median)", "compile cost"):
        table.add_column(col, justify="left" if col == "run" else "right")
    for label, (cmd, env) in runs.items():
        cache = Path(tempfile.mkdtemp(prefix="cache-", dir=ctx.tmp))
        env = {**env, "STACKX_CACHE_DIR": str(cache)}
        out = ["--out", str(ctx.tmp / "compile-out"), "-q"]
        cold = wall([*cmd, *out], 1, env, warm=False)[0]
        cached = statistics.median(wall([*cmd, *out], ctx.repeats(3), env, warm=False))
        res[label] = {"empty_cache_s": cold, "cached_s": cached, "compile_s": cold - cached}
        table.add_row(label, f"{cold:.2f}", f"{cached:.2f}", f"{cold - cached:.2f}")
        shutil.rmtree(cache, ignore_errors=True)
    console.print(table)
    console.print(f"  default (auto) runs a batch plain below STACKX_JIT_WORK = {kernel.min_work():,} of work "
                  "(steps x contact visits, in box-steps at each solver's default passes), so small runs never "
                  "wait for a compile")
    return res


# ------------------------------------------------------------------------------------------- main


def holds(sub: Subject) -> tuple[bool, float, float]:
    """Step a tall column to its end: whether it holds as the hard cases judge depth (final depth <= 2 x the
    lab's slop, no box ever half-way into another), with the final depth and the reach."""
    run, state = sub.stackx(sub.spec.runs[0].steps)
    run()
    depth, reach = float(state.penetration().max()), float(state.reach.max())
    return depth <= 2 * LAB_SLOP and reach <= 1.0, depth, reach


def default_tall_solver(tmp: Path) -> dict[str, Any]:
    """The first of ``TALL_CANDIDATES`` that is registered and holds tall-1000 at its defaults (else the first
    registered one, else the lab solver), saying what it tried."""
    names = {e.name for e in solvers.entries()}
    tried = []
    for name in (n for n in TALL_CANDIDATES if n in names):
        ok, depth, reach = holds(Subject(write_config(tmp, "pick-tall-1000", tall_doc(1000, {"name": name}))))
        tried.append(f"{name} (final depth {depth:.4f} m, reach {reach:.3f}: {'holds' if ok else 'does not hold'})")
        if ok:
            console.print(f"tall columns: {name}, the first solver that holds tall-1000; tried " + "; ".join(tried))
            return {"name": name}
    fallback = next((n for n in TALL_CANDIDATES if n in names), "pgs")
    console.print(f"tall columns: no candidate holds tall-1000 ({'; '.join(tried) or 'none registered'}); "
                  f"timing {fallback}")
    return {"name": fallback}


def run(json_path: Path, quick: bool, tall_solver: dict[str, Any] | None) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="stackx-bench-") as tmp:
        folder = Path(tmp)
        native = build(folder)
        ctx = Context(native, folder, quick, tall_solver or default_tall_solver(folder))
        console.print(f"C: {' '.join(native.command) if isinstance(native, Native) else native}")
        doc: dict[str, Any] = {"machine": _machine(), "c_compiler": getattr(native, "command", None) or native,
                               "quick": quick}
        for section in (scene_06, tall, sweep, commands, compile_cost):
            busy = _busy_cores()
            if busy is not None and busy > BUSY:
                console.print(f"[yellow]other processes kept {busy:.1f} cores busy just before {section.__name__}: "
                              "its figures (above all the parallel sweep's) will be low[/yellow]")
            t0 = time.perf_counter()
            doc[section.__name__] = section(ctx)
            doc[section.__name__].update(section_s=time.perf_counter() - t0, busy_cores_before=busy)
        doc["targets"] = ctx.targets
    _targets_table(ctx.targets)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(doc, indent=2, default=str) + "\n")
    console.print(f"figures written to {json_path}")
    return doc


def _targets_table(targets: list[dict[str, Any]]) -> None:
    table = Table(title="targets")
    for col in ("target", "goal", "measured", "met"):
        table.add_column(col, justify="left" if col in ("target", "goal") else "right")
    for t in targets:
        met = "-" if t["met"] is None else ("yes" if t["met"] else "NO")
        table.add_row(t["target"], t["goal"], f"{_fmt(t['measured'])} {t['unit']}", met)
    console.print(table)


def _busy_cores(seconds: float = 1.0) -> float | None:
    """How many cores other processes kept busy over ``seconds`` while this one slept (Linux ``/proc/stat``)."""

    def times() -> tuple[int, int]:
        fields = [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
        return sum(fields), fields[3] + fields[4]  # all, idle + iowait

    try:
        total0, idle0 = times()
        time.sleep(seconds)
        total1, idle1 = times()
    except (OSError, ValueError, IndexError):
        return None
    share = 1.0 - (idle1 - idle0) / max(1, total1 - total0)
    return share * (os.cpu_count() or 1)


def _machine() -> dict[str, Any]:
    from importlib import metadata

    versions = {}
    for dist in ("numpy", "numba"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "python": sys.version.split()[0], **versions,
            "date": time.strftime("%Y-%m-%d %H:%M")}
