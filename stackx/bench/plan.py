"""Which solver runs a case, with which parameters, over which values of its cost knob.

Nothing here assumes which solvers exist: every solver comes from the registry, its cost knob is the one it
declares (a ``knob`` class attribute naming a parameter) or else its ``iterations`` or ``substeps``
parameter, and the case's settings (``bench.set``) reach only the solvers whose parameters have them.

A solver's parameters on a case are, in order: its defaults; the config's own ``solver:`` section when the
config names this solver (so the lab solver runs at the lab's settings, and its knob value joins the
sweep); ``bench.set``; a claim's baseline, for the runs beside the case's setting; the knob value.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ValidationError

from stackx import registry
from stackx.bench.case import BenchSection
from stackx.config.experiment import ExperimentSpec, above_hint, parse_key
from stackx.errors import ConfigError
from stackx.config.spec import RunSpec
from stackx.config.yamlsrc import Path

KNOB_FIELDS = ("iterations", "substeps")  # the usual names of a cost knob, when a solver declares none
CASE, BASELINE = "case", "baseline"


@dataclass
class SolverPlan:
    """One solver on one case: the runs it gets (knob value -> parameters), per variant."""

    solver: str
    solver_cls: type
    knob: str | None
    values: list[int]                                  # knob values; empty without a knob (one run, keyed 0)
    params: dict[str, dict[int, BaseModel]] = field(default_factory=dict)  # variant -> knob value -> params
    applied: list[str] = field(default_factory=list)   # bench.set keys this solver has
    skipped: list[str] = field(default_factory=list)   # bench.set keys it has not
    claim: bool = False                                # whether it runs the claim's baseline too
    own: int | None = None                             # the config's own knob value, when it names this solver


@dataclass
class Case:
    """A config made ready for the bench: its one run, its bench section and its plans."""

    spec: ExperimentSpec
    run: RunSpec
    section: BenchSection
    plans: list[SolverPlan]

    @property
    def name(self) -> str:
        return self.spec.name


def knob_of(solver_cls: type) -> str | None:
    """The parameter that trades CPU for accuracy: declared as ``knob``, or the usual field names."""
    declared = getattr(solver_cls, "knob", None)
    if declared is not None:
        return str(declared)
    fields = solver_cls.Params.model_fields
    return next((f for f in KNOB_FIELDS if f in fields), None)


def _get(data: Any, path: tuple[str | int, ...]) -> tuple[bool, Any]:
    for part in path:
        if isinstance(data, dict) and part in data:
            data = data[part]
        else:
            return False, None
    return True, data


def _put(data: dict[str, Any], path: tuple[str | int, ...], value: Any) -> None:
    for part in path[:-1]:
        data = data[part]
    data[path[-1]] = copy.deepcopy(value)


def _validate(cls: type, data: dict[str, Any], spec: ExperimentSpec, places: dict[str, Path]) -> BaseModel:
    """The solver's params from ``data``; a refusal points at the config key that set the refused value
    (``places``: dotted solver key -> where the bench section sets it), else at the solver section."""
    try:
        return cls.Params.model_validate(data)  # type: ignore[no-any-return]
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        key = ".".join(str(p) for p in err["loc"])
        where = places.get(key, ("solver",))
        raise spec.source.error(where, f"solver {cls.plugin_name!r} refuses {key} = {err.get('input')!r}: "
                                       f"{err['msg']}") from None


def _defaults(cls: type, run: RunSpec) -> dict[str, Any] | None:
    """The solver's starting parameters as plain data, or None when it has required parameters."""
    if cls is run.solver_cls:
        return run.solver_params.model_dump(mode="python")
    try:
        return cls.Params().model_dump(mode="python")  # type: ignore[no-any-return]
    except ValidationError:
        return None


def _with(data: dict[str, Any], sets: dict[str, Any]) -> tuple[dict[str, Any], list[str], list[str]]:
    """``data`` with the dotted ``sets`` it has applied: (new data, keys applied, keys it does not have)."""
    out, applied, missing = copy.deepcopy(data), [], []
    for key, value in sets.items():
        path = parse_key(key)
        if _get(out, path)[0]:
            _put(out, path, value)
            applied.append(key)
        else:
            missing.append(key)
    return out, applied, missing


def plan_solver(cls: type, spec: ExperimentSpec, run: RunSpec, section: BenchSection) -> SolverPlan | str:
    """The plan of one solver on a case, or the reason it cannot run it."""
    name = cls.plugin_name
    if run.scene.model not in cls.models:
        return f"steps {', '.join(cls.models)} scenes, not {run.scene.model!r}"
    defaults = _defaults(cls, run)
    if defaults is None:
        return "has parameters without defaults"
    plan = SolverPlan(name, cls, knob_of(cls), [])
    if plan.knob is not None and not _get(defaults, parse_key(plan.knob))[0]:
        return f"its knob {plan.knob!r} is not one of its parameters"
    base, plan.applied, plan.skipped = _with(defaults, section.set)
    variants = {CASE: base}
    claim = section.claim
    if claim is not None and plan.applied:
        baseline, _, missing = _with(base, claim.baseline)
        if not missing:  # a solver runs the lab's side of a claim only when it has every setting of it
            variants[BASELINE] = baseline
            plan.claim = True
    places: dict[str, Path] = {key: ("bench", "set", key) for key in section.set}
    if plan.knob is not None:
        values = set(section.knobs.get(name, section.knob))
        found, own = _get(base, parse_key(plan.knob))
        if cls is run.solver_cls and found and isinstance(own, int):
            values.add(own)  # the config's own setting (the lab's 15 iterations) is always measured
            plan.own = own
        plan.values = sorted(values)
        places[plan.knob] = ("bench", "knobs", name) if name in section.knobs else ("bench", "knob")
    for variant, data in variants.items():
        if variant == BASELINE and claim is not None:
            places.update({key: ("bench", "claim", "baseline", key) for key in claim.baseline})
        plan.params[variant] = {value: _validate(cls, _with(data, {plan.knob: value})[0] if plan.knob else data,
                                                 spec, places)
                                for value in plan.values or [0]}
    return plan


def load_case(spec: ExperimentSpec, names: list[str] | None) -> tuple[Case, dict[str, str]]:
    """Make ``spec`` a bench case for the solvers ``names`` (None: every built-in or installed solver).

    Returns the case and, per solver left out, why.
    """
    if len(spec.runs) != 1:
        raise ConfigError(f"a bench case has one run (scene, solver, dt, steps); this config has "
                          f"{len(spec.runs)}: drop 'runs'/'sweep'", file=spec.file)
    run = spec.runs[0]
    section = spec.bench or BenchSection()
    for name in section.knobs:
        try:
            registry.solvers.get(name)
        except ConfigError as exc:
            raise spec.source.error(("bench", "knobs", name), exc.message, key=True) from None
    try:
        chosen = chosen_solvers(names)
    except registry.UnknownName as exc:  # a local solver named with --solvers may sit in a plugins/ folder above
        raise ConfigError(f"--solvers: {exc.hinted(above_hint(spec.file))}", file=spec.file) from None
    plans, left_out = [], {}
    for cls in chosen:
        plan = plan_solver(cls, spec, run, section)
        if isinstance(plan, str):
            left_out[cls.plugin_name] = plan
        else:
            plans.append(plan)
    return Case(spec, run, section, plans), left_out


def chosen_solvers(names: list[str] | None) -> list[type]:
    """The solver classes to bench: those named (unknown names, and engines that are not installed, fail with
    what to do), or by default every built-in and installed solver except those that say otherwise with
    ``bench_by_default = False`` (the engines: stepped one Python call per step, a tall case takes them
    minutes) and local plugin files (they may be plain Python): both join when named."""
    if names:
        chosen = [registry.solvers.get(n) for n in names]
        for name, cls in zip(names, chosen):
            registry.require_available("solver", name, cls)
        return chosen
    return [cls for e in registry.solvers.entries()
            if e.origin == "built-in" or e.origin.startswith("entry point")
            if getattr(cls := registry.solvers.get(e.name), "bench_by_default", True)]
