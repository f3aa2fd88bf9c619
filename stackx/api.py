"""stackx from Python (a notebook, a script): load a config or build one from a dict, override it, run it and
get numpy arrays back, bench solvers and get their records as a table, and draw states.

    from stackx import api

    spec = api.load("configs/06-stack.yaml", overrides={"solver.iterations": 4})
    result = api.run(spec, steps=range(0, 901, 10))
    stack = result["main"]
    stack.heights          # (recorded steps, boxes) array of box centres, bottom box first
    stack.measures["max_depth"]
    api.write(spec, result, "out")            # the config's own artifacts, as `stackx run` writes them
    table = api.bench(["configs/hard/tall-20.yaml"], solvers=["exact", "warm-start"])  # a list of dicts
    api.frame(table)                          # the same records as a pandas DataFrame, when pandas is there

The command line is built on the same functions: ``stackx run`` is ``load``, then the runner, then ``write``
for every config; ``stackx bench`` is ``bench`` with an output folder.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from stackx.config.experiment import ExperimentSpec, apply_sets, build, local_plugins
from stackx.config.experiment import load as load_file
from stackx.errors import ConfigError
from stackx.run.results import ExperimentResult, RunResult
from stackx.run.runner import run_experiment
from stackx.config.yamlsrc import load_text


def _sets(overrides: Mapping[str, Any] | None) -> list[str]:
    """``{"solver.iterations": 4}`` as the ``--set`` texts the loader applies (values written as YAML)."""
    return [f"{key}={yaml.safe_dump(value, default_flow_style=True).strip().removesuffix('...').strip()}"
            for key, value in (overrides or {}).items()]


def load(config: str | Path | Mapping[str, Any], overrides: Mapping[str, Any] | None = None,
         plugins: str | Path | None = None, name: str = "notebook") -> ExperimentSpec:
    """A validated config from a YAML file, or from a dict shaped like one (``name`` stands for its file name
    in errors, which then name the key without a line). ``overrides`` are dotted keys as for ``--set``;
    ``plugins`` a folder of local plugins (when not given: for a file, the ``plugins/`` folder in its own folder,
    never one above; for a dict, none). Bad input raises ``ConfigError`` with the same one-line message as the
    command line."""
    folder = Path(plugins) if plugins is not None else None
    if not isinstance(config, Mapping):
        return load_file(str(config), _sets(overrides), folder)
    local_plugins(folder, None)
    try:
        src = load_text(yaml.safe_dump(dict(config), sort_keys=False), name)
        if overrides:
            src = apply_sets(src, _sets(overrides))
        return build(src)
    except ConfigError as exc:  # the dict's YAML text is never seen: its lines and columns mean nothing
        raise ConfigError(exc.message, file=exc.file, key=exc.key) from None


@dataclass
class Run:
    """One run's recorded states as arrays (rows: the recorded steps, in order) and its measures."""

    name: str
    solver: str
    dt: float
    steps: np.ndarray  # the steps whose state (before that step) was recorded
    states: dict[str, np.ndarray]  # each field of the model's state, shaped (steps, bodies)
    measures: dict[str, Any]
    us_per_step: float

    @property
    def time(self) -> np.ndarray:
        """Seconds at each recorded state."""
        return self.steps * self.dt

    @property
    def heights(self) -> np.ndarray:
        """Box centres (m), on the column model."""
        return self.states["y"]

    @property
    def velocities(self) -> np.ndarray:
        """Box velocities (m/s, up positive), on the column model."""
        return self.states["v"]


class Result(Mapping[str, Run]):
    """Runs by name, in the config's order; ``.experiment`` is what ``write`` draws from."""

    def __init__(self, experiment: ExperimentResult, runs: dict[str, Run]) -> None:
        self.experiment, self._runs = experiment, runs

    def __getitem__(self, name: str) -> Run:
        return self._runs[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._runs)

    def __len__(self) -> int:
        return len(self._runs)

    def metrics(self) -> dict[str, dict[str, Any]]:
        """Every run's measures, by run name (what the ``metrics`` sink writes)."""
        return {name: dict(run.measures) for name, run in self._runs.items()}


def _arrays(r: RunResult, steps: list[int]) -> dict[str, np.ndarray]:
    """The model's state fields at ``steps`` as (steps, bodies) arrays; a run whose number of bodies changes
    between them (a scene event) is refused, since its rows would not line up."""
    fields = type(r.final).FIELDS
    out = {}
    for name in fields:
        rows = [np.asarray(getattr(r.frames[k], name))[0] for k in steps]
        shapes = {row.shape for row in rows}
        if len(shapes) > 1:
            raise ConfigError(f"run {r.name!r} changes its number of bodies between the steps asked for (a scene "
                              "event): ask for steps on one side of it")
        if rows and rows[0].ndim == 1:
            out[name] = np.stack(rows)
    return out


def run(spec: ExperimentSpec, steps: Iterable[int] | None = None, progress: bool = False) -> Result:
    """Step every run of ``spec``. The states before ``steps`` are kept (beside what the config's outputs
    draw); default: every step, which costs a copy of the state per step, so pass a range for long runs."""
    wanted = sorted(set(range(max(r.steps for r in spec.runs) + 1) if steps is None else steps))
    bar = None
    if progress:
        from rich.progress import Progress

        bar = Progress(transient=True)
    if bar is not None:
        with bar:
            task = bar.add_task(spec.name, total=sum(r.steps for r in spec.runs))
            experiment = run_experiment(spec, lambda n: bar.advance(task, n), record=set(wanted))
    else:
        experiment = run_experiment(spec, record=set(wanted))
    runs = {}
    for r in experiment.runs:
        kept = [k for k in wanted if 0 <= k <= r.spec.steps]
        runs[r.name] = Run(r.name, r.spec.solver_cls.plugin_name, r.spec.dt, np.array(kept, dtype=np.int64),
                           _arrays(r, kept), dict(r.measures), r.us_per_step)
    return Result(experiment, runs)


def write(spec: ExperimentSpec, result: Result, out: str | Path) -> list[Path]:
    """Write the config's outputs (sinks and renderers) for ``result`` into ``out``, with its manifest entry,
    as ``stackx run`` does; return the files written."""
    from stackx.run.session import write as write_all

    return write_all(spec, result.experiment, Path(out))


def picture(result: Result, run: str, step: int) -> bytes:
    """The world of ``run`` before ``step`` (a recorded step), drawn as the stack picture is with the default
    style (PNG bytes): the column by the lab's rules, a planar world fitted to the picture."""
    from stackx.render.draw import framed, picture as draw
    from stackx.render.style import Style

    experiment_run = result.experiment.run(run)
    if step not in experiment_run.frames:
        raise ConfigError(f"step {step} of run {run!r} was not recorded; pass it in run(..., steps=...)")
    state = experiment_run.frames[step]
    return draw(state, framed([state], Style())).png_bytes()


def bench(configs: Iterable[str | Path], solvers: Iterable[str] | None = None, out: str | Path | None = None,
          overrides: Mapping[str, Any] | None = None, quiet: bool = True) -> list[dict[str, Any]]:
    """Bench ``configs`` (files or folders) with ``solvers`` (default: every built-in and installed one) and
    return one record per run, always a list of dicts with the fields docs/api.md lists (identity, verdicts,
    costs in µs, errors in m/s, then the model's measures), whatever is installed: ``frame(rows)`` makes a
    pandas DataFrame of them. With ``out`` the bench's folder (``bench.json``, ``report.html``, plots) is
    written too, as ``stackx bench`` does."""
    from stackx.bench.command import bench as run_bench

    folder = Path(out) if out is not None else None
    names = list(solvers) if solvers is not None else None
    results = run_bench([str(c) for c in configs], names, folder, quiet=quiet, sets=_sets(overrides))
    return [_row(rec) for case in results for rec in case.records]


def frame(rows: Iterable[Mapping[str, Any]]) -> Any:
    """``bench``'s records as a pandas DataFrame, one row per run and one column per field, in their order.
    pandas is not a dependency of stackx: without it this raises ``ImportError`` saying so."""
    try:
        import pandas
    except ImportError as exc:
        raise ImportError("api.frame needs pandas, which stackx does not install: pip install pandas "
                          "(api.bench's records are plain dicts without it)") from exc
    return pandas.DataFrame.from_records([dict(row) for row in rows])


def _row(rec: Any) -> dict[str, Any]:
    """A bench record as flat columns: identity, verdict, cost, error, then every measure."""
    return {"case": rec.case, "solver": rec.solver, "knob": rec.knob, "value": rec.value, "variant": rec.variant,
            "passed": rec.passed, "broke": rec.broke, "blew_up": rec.blew_up, "crushed_at": rec.crushed_at,
            "us_per_step": rec.us_per_step, "us_per_call": rec.us_per_call,
            "error_rms": rec.error.get("rms"), "error_max": rec.error.get("max"),
            **{f"passed_{name}": v["passed"] for name, v in rec.criteria.items()}, **rec.measures}
