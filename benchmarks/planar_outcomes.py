"""``python -m benchmarks.planar_outcomes``: every planar solver against every planar case, judged by the bench's
criteria, the matrix of docs/planar.md.

``stackx bench configs/planar/`` also solves every step's reference problem and times every knob value, which
takes an hour on the planar cases with pyramid-20; this asks only what the matrix's cells ask. Per case and
solver (every registered solver whose ``models`` include ``planar`` and that can run here, engines included;
``planar-exact`` is the reference and gets its own column): whether it meets the case's stated outcome at its
defaults (``pass``, or the bench's word for the first check that failed: drifted, turned, crushed, launched,
sunk, slides wrong, did not tip, ...) and its µs per step; then the cheapest value of its cost knob that holds,
trying 1, 2, 4, ... up to a cap (``CAPS``) and stopping at the first that passes, and that run's µs per step;
and per case the cheapest run that holds it.

Each config runs with its solver section replaced by ``{name: SOLVER}`` (and the knob value where one is tried),
so a config's own tuning and its ``bench.set`` are not applied, and without outputs; the config's
``bench.criteria`` limits apply. Every run's outcome is kept in the JSON file given by ``--cache`` as soon as it
ends, keyed by the case's settings (its YAML but the description), the solver and the knob value: an interrupted or partial run reruns only
the runs still missing, and ``--redo SOLVERS`` forgets a changed solver's runs. ``--jobs 2`` steps two runs at
once, in separate processes (the µs per step then share the machine with the other run). Kernels run compiled
(``STACKX_JIT=1`` unless set otherwise), so that µs per step compare across cells; a run stepping for under
``RETIME`` seconds is stepped again, up to ``REPEATS`` times, and the fastest time kept. ``--write FILE``
replaces the text between ``BEGIN`` and ``END`` in FILE with the matrix; without it the matrix is printed.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import math
import multiprocessing
import os
import platform
import signal
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

REFERENCE = "planar-exact"
CAP = 256                   # the largest knob value tried: iterations
CAPS = {"substeps": 64}     # per knob name where a smaller cap does (a substep costs a whole pass of the step)
BEGIN = "<!-- outcome matrix: python -m benchmarks.planar_outcomes writes the lines from here to its end mark -->"
END = "<!-- end of outcome matrix -->"
RETIME = 0.5               # s: a run stepping for less is stepped again, up to REPEATS times in all, the
REPEATS = 10               # fastest time kept: a run of milliseconds is at the mercy of the other processes
VERSION = 1                 # of the cache's layout; a cache of another version is refused, not misread


class Refusal(Exception):
    """Bad input (a cache of another layout, a file without the marks, a solver that cannot step planar
    scenes, a config not there): one line naming the file or name, exit code 2, nothing written."""


@dataclass(frozen=True)
class Case:
    """A config of the matrix: its path, its name (the file's stem) and a digest of its settings (``digest``),
    so that a cached outcome of an edited config is not reused."""

    path: Path
    name: str
    digest: str

    @classmethod
    def read(cls, path: Path) -> Case:
        return cls(path, path.stem, digest(path))


def digest(path: Path) -> str:
    """What a run of the config depends on, hashed: its YAML without its ``description`` (rewording what a case
    is does not run it again), or its bytes where it is not a YAML mapping."""
    import yaml

    raw = path.read_bytes()
    try:
        data = yaml.safe_load(raw)
    except yaml.YAMLError:
        data = None
    if isinstance(data, dict):
        data.pop("description", None)
        raw = json.dumps(data, sort_keys=True, default=str).encode()
    return hashlib.sha256(raw).hexdigest()[:16]


@dataclass(frozen=True)
class Trial:
    """One run: ``solver`` on ``case`` at its defaults (``value`` None) or with its knob at ``value``."""

    case: Case
    solver: str
    knob: str | None
    value: int | None

    @property
    def key(self) -> str:
        """The cache's key: case, content digest, solver and setting."""
        return f"{self.case.name}@{self.case.digest}|{self.solver}|{'default' if self.value is None else self.value}"


@dataclass(frozen=True)
class Outcome:
    """What one run gave: whether it met every criterion, the bench's word for what failed (empty when it
    passed), µs per step (NaN where it did not finish) and whether its kernels ran compiled."""

    passed: bool
    word: str
    us: float
    compiled: bool = True

    @classmethod
    def load(cls, data: Mapping[str, Any]) -> Outcome:
        return cls(bool(data["passed"]), str(data["word"]), float(data["us"]), bool(data.get("compiled", True)))


@dataclass(frozen=True)
class Cell:
    """One solver on one case: the run at its defaults, and the cheapest knob value that held with its run
    (None where none up to ``cap`` did, or the solver has no knob); ``complete`` once nothing is left to run."""

    solver: str
    knob: str | None
    cap: int
    default: Outcome | None
    holds_at: int | None
    holds: Outcome | None
    complete: bool


def ladder(cap: int) -> list[int]:
    """The knob values tried, cheapest first: 1, 2, 4, ... up to ``cap`` (``cap`` itself always last)."""
    out, v = [], 1
    while v < cap:
        out.append(v)
        v *= 2
    return out + [cap]


def cap_of(knob: str | None) -> int:
    """The largest value of ``knob`` the search tries (``CAPS``, else ``CAP``)."""
    return CAPS.get(knob or "", CAP)


def trials(case: Case, solver: str, knob: str | None, search: bool = True) -> list[Trial]:
    """Every run a cell may take, in the order it takes them: the defaults, then the knob's ladder."""
    out = [Trial(case, solver, knob, None)]
    if knob is not None and search:
        out += [Trial(case, solver, knob, v) for v in ladder(cap_of(knob))]
    return out


def next_trial(case: Case, solver: str, knob: str | None, done: Mapping[str, Outcome],
               search: bool = True) -> Trial | None:
    """The next run a cell needs given the outcomes ``done`` (by key), or None when the cell is complete: the
    defaults first, then the knob values in order until one passes."""
    for t in trials(case, solver, knob, search):
        got = done.get(t.key)
        if got is None:
            return t
        if t.value is not None and got.passed:
            return None
    return None


def cell(case: Case, solver: str, knob: str | None, done: Mapping[str, Outcome], search: bool = True) -> Cell:
    """What the outcomes ``done`` say of one cell so far; without ``search``, of its defaults alone."""
    default = done.get(Trial(case, solver, knob, None).key)
    holds_at, holds = None, None
    for t in trials(case, solver, knob, search)[1:]:
        got = done.get(t.key)
        if got is not None and got.passed:
            holds_at, holds = t.value, got
            break
    complete = next_trial(case, solver, knob, done, search) is None
    return Cell(solver, knob if search else None, cap_of(knob), default, holds_at, holds, complete)


class Cache:
    """Outcomes by trial key in a JSON file, written whole after every new outcome (a temporary file renamed
    over it, so an interrupt leaves the last complete file)."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.outcomes: dict[str, Outcome] = {}
        if path is not None and path.exists():
            data = json.loads(path.read_text())
            if data.get("version") != VERSION:
                raise Refusal(f"{path}: a cache of layout {data.get('version')!r}, this command writes "
                                 f"{VERSION}; give another --cache file or delete it")
            self.outcomes = {k: Outcome.load(v) for k, v in data["outcomes"].items()}

    def put(self, key: str, outcome: Outcome) -> None:
        self.outcomes[key] = outcome
        self.save()

    def forget(self, solvers: Iterable[str]) -> int:
        """Drop every outcome of ``solvers`` (one whose code changed); how many were dropped."""
        names = set(solvers)
        gone = [k for k in self.outcomes if k.split("|")[1] in names]
        for k in gone:
            del self.outcomes[k]
        if gone:
            self.save()
        return len(gone)

    def save(self) -> None:
        if self.path is None:
            return
        tmp = self.path.with_name(self.path.name + ".tmp")
        tmp.write_text(json.dumps({"version": VERSION, "outcomes": {k: asdict(v) for k, v in
                                                                    sorted(self.outcomes.items())}}, indent=1))
        os.replace(tmp, self.path)


def run_trial(path: str, solver: str, knob: str | None, value: int | None) -> Outcome:
    """Run ``solver`` on the config at ``path`` (its defaults, or ``knob`` = ``value``) and judge it as the
    bench does: ``pass``, or the word of the first failed check; a run that blew up is ``blew up``, one the
    config or solver refused is ``refused``, one that raised anything else ``error`` (said on stderr)."""
    from stackx.bench.criteria import failed_words, passed, run_verdicts
    from stackx.config.experiment import load
    from stackx.errors import BlowUp, StackxError
    from stackx.run.runner import run_experiment

    setting = f", {knob}: {value}" if value is not None else ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # pybox2d's SWIG types, on import
        try:
            spec = load(path, [f"solver={{name: {solver}{setting}}}", "outputs=[]"])
            result = run_experiment(spec).runs[0]
            us = quickest(spec, result)
        except BlowUp:
            return Outcome(False, "blew up", math.nan)
        except StackxError as exc:
            print(f"{path}: {solver} refused: {exc}", file=sys.stderr)
            return Outcome(False, "refused", math.nan)
        except Exception as exc:  # a solver that breaks on a case fails that cell, not the matrix
            print(f"{path}: {solver} raised {type(exc).__name__}: {exc}", file=sys.stderr)
            return Outcome(False, "error", math.nan)
    judged = run_verdicts(result, spec.bench.criteria if spec.bench is not None else None)
    if judged is None:
        return Outcome(True, "not judged", us, result.compiled)
    verdicts, measures = judged
    word = "" if passed(verdicts) else failed_words(verdicts, measures).split(", ")[0]
    return Outcome(not word, word, us, result.compiled)


def quickest(spec: Any, result: Any) -> float:
    """µs per step of a run: its own, or where its stepping took under ``RETIME`` seconds, the fastest of up to
    ``REPEATS`` runs that together step for about that long (the same run, so the same outcome; on a shared
    machine one descheduling makes a millisecond run look ten times slower)."""
    from stackx.run.runner import run_experiment

    us, spent, runs = result.us_per_step, result.wall_seconds, 1
    while spent < RETIME and runs < REPEATS:
        again = run_experiment(spec).runs[0]
        us, spent, runs = min(us, again.us_per_step), spent + again.wall_seconds, runs + 1
    return float(us)


def _run(trial: Trial) -> Outcome:
    return run_trial(str(trial.case.path), trial.solver, trial.knob, trial.value)


Runner = Callable[[Trial], Outcome]


def fill(cells: list[tuple[Case, str, str | None]], cache: Cache, runner: Runner = _run, jobs: int = 1,
         search: bool = True, say: Callable[[str], None] = lambda line: None) -> int:
    """Run every trial the ``cells`` (case, solver, knob) still need, keeping each outcome in ``cache`` as it
    ends; ``jobs`` > 1 runs that many at once in separate processes (``runner`` must then be picklable). A
    cell's knob values are tried one after another, each only once the last failed. Returns the runs made."""
    made = 0
    if jobs <= 1:
        for case, solver, knob in cells:
            while (t := next_trial(case, solver, knob, cache.outcomes, search)) is not None:
                cache.put(t.key, runner(t))
                made += 1
                say(_said(t, cache.outcomes[t.key]))
        return made
    running: dict[Future[Outcome], Trial] = {}
    busy: set[tuple[str, str]] = set()
    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"))
    try:
        while True:
            for case, solver, knob in cells:
                if len(running) >= jobs:
                    break
                if (case.name, solver) in busy:
                    continue
                t = next_trial(case, solver, knob, cache.outcomes, search)
                if t is not None:
                    running[pool.submit(runner, t)] = t
                    busy.add((case.name, solver))
            if not running:
                return made
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                t = running.pop(future)
                busy.discard((t.case.name, t.solver))
                cache.put(t.key, future.result())
                made += 1
                say(_said(t, cache.outcomes[t.key]))
    finally:
        _stop(pool, bool(running))


def _stop(pool: ProcessPoolExecutor, interrupted: bool) -> None:
    """Shut the pool down; when runs are still going (an interrupt), end its worker processes rather than wait
    for their runs, whose outcomes would not be kept."""
    workers = list((getattr(pool, "_processes", None) or {}).values()) if interrupted else []
    pool.shutdown(wait=not interrupted, cancel_futures=True)
    for process in workers:
        process.terminate()


def _said(t: Trial, o: Outcome) -> str:
    at = "defaults" if t.value is None else f"{t.knob} {t.value}"
    return f"{t.case.name} {t.solver} {at}: {o.word or 'pass'} {_us(o)}"


def _us(o: Outcome) -> str:
    if math.isnan(o.us):
        return "-"
    return f"{o.us:,.0f} µs" + ("" if o.compiled else " py")


def show(c: Cell) -> str:
    """A cell as text: ``pass 41 µs`` or ``turned 40 µs`` at the defaults, then the cheapest knob value that
    held, ``· 4: 35 µs``, or ``· none to 256``; ``-`` where nothing has run yet, ``…`` after what is missing."""
    if c.default is None:
        return "-"
    text = f"{c.default.word or 'pass'} {_us(c.default)}"
    if c.knob is None:
        return text
    if c.holds is not None:
        return f"{text} · {c.holds_at}: {_us(c.holds)}"
    return f"{text} · none to {c.cap}" if c.complete else f"{text} · …"


def cheapest(cells: Iterable[Cell]) -> str:
    """The run that held the case at the fewest µs per step, among the defaults and the knob values found
    (``-`` where none held)."""
    best: tuple[float, str] | None = None
    for c in cells:
        short = c.solver.removeprefix("planar-")
        runs = [(c.default, short)] if c.default is not None and c.default.passed else []
        if c.holds is not None:
            runs.append((c.holds, f"{short} {c.holds_at}"))
        for o, name in runs:
            if not math.isnan(o.us) and (best is None or o.us < best[0]):
                best = (o.us, f"{name} ({_us(o)})")
    return best[1] if best else "-"


def matrix(cases: list[Case], solvers: list[tuple[str, str | None]], done: Mapping[str, Outcome],
           reference: str | None = REFERENCE, search: bool = True) -> list[str]:
    """The markdown table: a row per case, a column for the reference, one per solver (headed with its knob),
    and the cheapest run that held the case."""
    others = [(s, k) for s, k in solvers if s != reference]
    head = ["case"] + ([f"`{reference}`"] if reference else []) + [
        f"`{s.removeprefix('planar-')}`" + (f" ({k})" if k else "") for s, k in others] + ["cheapest that holds"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for case in cases:
        row = [f"`{case.name}`"]
        if reference:
            row.append(show(cell(case, reference, None, done, False)))
        found = [cell(case, s, k, done, search) for s, k in others]
        row += [show(c) for c in found] + [cheapest(found)]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def machine() -> str:
    """The CPU's model name and core count, for the line saying where the figures were measured."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores"


def marks(path: Path) -> tuple[str, int, int]:
    """The text of ``path`` and where ``BEGIN`` and ``END`` start in it; refused when either is missing or
    they come in the wrong order."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise Refusal(f"{path}: cannot read it ({exc.strerror})") from None
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise Refusal(f"{path}: no '{BEGIN}' line followed by '{END}' to write the matrix between; add both")
    return text, start, end


def write_between(path: Path, lines: list[str]) -> None:
    """Replace what lies between ``BEGIN`` and ``END`` in ``path`` with ``lines``; refuses, changing nothing,
    when the file lacks either mark or has them in the wrong order."""
    text, start, end = marks(path)
    head = text[:start + len(BEGIN)]
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(head + "\n" + "\n".join(lines) + "\n" + text[end:])
    os.replace(tmp, path)


def planar_solvers(names: list[str] | None = None) -> list[tuple[str, str | None]]:
    """(name, knob) of every registered solver that steps the planar model and can run here (an engine whose
    package is missing cannot), or of ``names``; the reference first."""
    from stackx import registry
    from stackx.bench.plan import knob_of
    from stackx.errors import StackxError

    chosen = names or [e.name for e in registry.solvers.entries()]
    out = []
    for name in chosen:
        try:
            cls = registry.solvers.get(name)
        except StackxError as exc:
            raise Refusal(str(exc).splitlines()[0]) from None
        if "planar" not in getattr(cls, "models", ()) or registry.unavailable(cls):
            if names:
                raise Refusal(f"solver {name!r} does not step the planar model here "
                                 f"({registry.unavailable(cls) or 'models: ' + ', '.join(cls.models)})")
            continue
        out.append((name, None if name == REFERENCE else knob_of(cls)))
    return sorted(out, key=lambda sk: (sk[0] != REFERENCE, sk[0].startswith("planar-") is False, sk[0]))


def configs(given: list[str]) -> list[Case]:
    """The cases named, folders giving every ``*.yaml`` in them."""
    paths = [p for c in map(Path, given) for p in (sorted(c.glob("*.yaml")) if c.is_dir() else [c])]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise Refusal(f"no config at {', '.join(missing)}")
    return [Case.read(p) for p in paths]


def shown_command(argv: list[str]) -> str:
    """The command line as the made-by line shows it: without ``--cache`` and ``--write`` and their files,
    which say where things were kept, not what was run."""
    out, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in ("--cache", "--write"):
            skip = True
        elif not arg.startswith(("--cache=", "--write=")):
            out.append(arg)
    return " ".join(["python -m benchmarks.planar_outcomes", *out])


def made_line(argv: list[str], jobs: int) -> str:
    """How and where the matrix was made."""
    today = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    at_once = "one run at a time" if jobs <= 1 else f"{jobs} runs at once"
    jit = {"1": "compiled", "0": "plain"}.get(os.environ.get("STACKX_JIT", "auto"), "compiled where it pays")
    return (f"Made by `{shown_command(argv)}` on {today}, {machine()}, "
            f"{at_once}, kernels {jit}; µs per step without compiling, `py` where a run's kernels ran plain.")


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> None:
    """The command; bad input is one line on stderr and exit code 2."""
    try:
        matrix_command(sys.argv[1:] if argv is None else argv)
    except Refusal as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None


def matrix_command(argv: list[str]) -> None:
    """Fill the cache for the cases and solvers asked, then print or write the matrix."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_outcomes",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="*", default=["configs/planar"], help="configs or folders of them")
    parser.add_argument("--solvers", help="comma-separated solver names (default: every planar solver here)")
    parser.add_argument("--cache", type=Path, help="JSON file keeping every run's outcome, read and extended")
    parser.add_argument("--jobs", type=int, default=1, help="runs at once, each in its own process")
    parser.add_argument("--no-search", action="store_true", help="only the defaults, no knob search")
    parser.add_argument("--redo", default="", help="comma-separated solvers whose cached runs are forgotten")
    parser.add_argument("--write", type=Path, help="markdown file whose matrix (between the marks) is replaced")
    args = parser.parse_args(argv)
    cases = configs(args.configs)
    solvers = planar_solvers(args.solvers.split(",") if args.solvers else None)
    cache = Cache(args.cache)
    if args.redo:
        cache.forget(args.redo.split(","))
    if args.write is not None:
        marks(args.write)  # before the runs, not after them
    cells = [(c, s, k) for c in cases for s, k in solvers]
    search = not args.no_search
    os.environ.setdefault("STACKX_JIT", "1")  # every run compiled, so that µs per step compare across cells
    signal.signal(signal.SIGTERM, _interrupt)  # a kill keeps what ended, as Ctrl-C does
    try:
        fill(cells, cache, jobs=args.jobs, search=search, say=lambda line: print(line, file=sys.stderr, flush=True))
    except KeyboardInterrupt:
        print("interrupted: the runs that ended are in the cache; run the same command again to go on",
              file=sys.stderr)
        raise SystemExit(130) from None
    reference = REFERENCE if any(s == REFERENCE for s, _ in solvers) else None
    lines = [made_line(argv, args.jobs), ""] + matrix(cases, solvers, cache.outcomes, reference, search)
    if args.write is not None:
        write_between(args.write, lines)
    else:
        print("\n".join(lines))


if __name__ == "__main__":
    main()
