"""Experiment configs: YAML in, validated run specifications out.

A config describes one experiment: a scene, a solver with its parameters, a step size and a run length,
optionally several named ``runs`` or a ``sweep`` grid that override any of those, and the ``outputs``
(sinks and renderers) that turn the results into files. Every plugin section is validated by the plugin's
own params model, and every error points at ``file:line:col`` with the key path.
"""

from __future__ import annotations

import copy
import itertools
import math
import os
import re
import reprlib
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path as FsPath
from typing import Annotated, Any, Iterator, NamedTuple

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StringConstraints, ValidationError, field_validator

from stackx import registry
from stackx.config import sizing
from stackx.bench.case import BenchSection
from stackx.errors import ConfigError
from stackx.config.limits import Limits
from stackx.outputs import Output, Renderer, clashes, confine, path_key
from stackx.config.spec import Plan, RunSpec
from stackx.config.yamlsrc import Mark, Path, Source, dotted, load_file, load_text

RUN_KEYS = ("scene", "solver", "gravity", "dt", "steps")
SIZE_KEYS = ("count", "rows")  # keys of a scene section that say how many boxes it generates
NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
FRACTION = r"^\s*\d+(\.\d*)?\s*/\s*\d+(\.\d*)?\s*$"  # dt: 1/60; also the schema's pattern (editors)
StepSize = Annotated[float, Field(gt=0, le=10.0, allow_inf_nan=False)]


def _fraction(value: Any) -> Any:
    """Accept ``dt: 1/60`` as well as a number, so a step size can be written as it is thought of."""
    if isinstance(value, str) and re.fullmatch(FRACTION, value):
        num, den = (Fraction(part.strip()) for part in value.split("/"))
        if den == 0:
            raise ValueError("division by zero")
        return float(num / den)
    return value


class Sweep(BaseModel):
    """A grid of values for dotted keys; each grid point is one run, named from ``name``."""

    model_config = ConfigDict(extra="forbid")
    name: str = Field("run{index}", description="run name template: {index} and {<grid key>} are filled in")
    grid: dict[str, Annotated[list[Any], Field(min_length=1)]] = Field(
        min_length=1, description="dotted key -> list of values; the product is run, last key fastest")


class ExperimentModel(BaseModel):
    """The top level of a config file."""

    model_config = ConfigDict(extra="forbid")
    description: str = Field("", description="what the experiment shows")
    scene: dict[str, Any] | None = Field(None, description="the scene plugin: {name: column, ...its params}")
    solver: dict[str, Any] | None = Field(None, description="the solver plugin: {name: pgs, ...its params}")
    gravity: float = Field(-9.8, allow_inf_nan=False, description="vertical acceleration (m/s^2, up positive)")
    dt: Annotated[StepSize, BeforeValidator(_fraction, json_schema_input_type=StepSize | Annotated[
        str, StringConstraints(pattern=FRACTION)])] = Field(
        1 / 60, description="step size (s); a fraction like 1/60 is accepted")
    steps: int = Field(0, ge=0, le=100_000_000, description="number of steps to run")
    runs: dict[str, dict[str, Any]] | None = Field(
        None, description="named runs, each a mapping of dotted keys to override (e.g. solver.iterations: 4)")
    sweep: Sweep | None = Field(None, description="a grid of overrides; one run per grid point")
    limits: Limits = Field(default_factory=Limits, description="when a run counts as blown up (max_speed) and "
                                                               "how big it may be (max_memory_mb, max_work)")
    outputs: list[dict[str, Any]] = Field(
        default_factory=list, description="sinks ({sink: NAME, ...}) and renderers ({render: NAME, ...})")
    bench: BenchSection | None = Field(None, description="settings of 'stackx bench' (criteria, knob values, "
                                                         "a lab claim); 'stackx run' ignores them")

    @field_validator("runs")
    @classmethod
    def _names(cls, runs: dict[str, dict[str, Any]] | None) -> dict[str, dict[str, Any]] | None:
        for name in runs or {}:
            if not NAME.match(name):
                raise ValueError(f"run name {name!r} must be letters, digits and _ (not starting with a digit)")
        return runs


@dataclass
class ExperimentSpec(Plan):
    """A validated config: its plan (runs and limits), its outputs and its ``bench`` section, with the source
    kept for later error positions."""

    outputs: list[Output] = field(default_factory=list)
    source: Source = field(default=None)  # type: ignore[assignment]
    resolved: dict[str, Any] = field(default_factory=dict)
    bench: BenchSection | None = None
    sets: list[str] = field(default_factory=list)  # the --set overrides it was loaded with
    plugins: str | None = None  # the local plugin folder it was loaded with, if any

    def frame_steps(self) -> set[int]:
        """The steps whose states the outputs draw."""
        wanted: set[int] = set()
        for output in self.outputs:
            wanted |= output.frame_steps(self)
        return wanted


# ---------------------------------------------------------------------------- dotted paths and overrides


class Named(str):
    """A list item chosen by name in a key (``outputs[frames]``), resolved to its index by ``select``."""


NAMING_KEYS = ("render", "sink", "name", "path")
"""The keys whose value names an item of a list (an output by its plugin or its file, a box by its name)."""


def parse_key(text: str, *, named: bool = False) -> Path:
    """``scene.boxes[0].y`` or ``scene.boxes.0.y`` -> ``("scene", "boxes", 0, "y")``; with ``named``, an item
    may also be chosen by name: ``outputs[frames].count`` -> ``("outputs", Named("frames"), "count")``."""
    out: list[str | int] = []
    token = re.compile(r"\[([^\[\]]+)\]|([^.\[\]]+)")
    at, dot = 0, True  # where the scan is; whether a name may start here (after a '.' or at the start)
    while at < len(text):
        m = token.match(text, at)
        if m is None or (m.group(2) is not None and not dot):
            raise ValueError(f"malformed key {text!r}")
        if m.group(1) is not None:
            index = m.group(1).strip()
            if not index.isdigit() and not (named and index):
                raise ValueError(f"malformed key {text!r}")
            out.append(int(index) if index.isdigit() else Named(index))
        else:
            out.append(int(m.group(2)) if m.group(2).isdigit() else m.group(2))
        at, dot = m.end(), False
        if at < len(text) and text[at] == ".":
            at, dot = at + 1, True
            if at == len(text):
                raise ValueError(f"malformed key {text!r}")
    if not out:
        raise ValueError(f"malformed key {text!r}")
    return tuple(out)


def select(data: Any, path: Path) -> Path:
    """``path`` with each ``Named`` item replaced by the index of the one item of its list that it names (by
    ``NAMING_KEYS``: ``outputs[frames]`` is the output rendering ``frames``, ``outputs[stack.png]`` the one
    writing ``stack.png``). Raises ``ValueError`` listing the names when none or several match."""
    out: list[str | int] = []
    node = data
    for part in path:
        if isinstance(part, Named):
            where = dotted(tuple(out)) or "the config"
            if not isinstance(node, list):
                raise ValueError(f"{where} is not a list, so [{part}] names nothing")
            names = [[str(item[k]) for k in NAMING_KEYS if isinstance(item, dict) and k in item] for item in node]
            hits = [i for i, item_names in enumerate(names) if part in item_names]
            listed = "; ".join(f"[{i}] " + " or ".join(n) for i, n in enumerate(names) if n) or "none has a name"
            if len(hits) != 1:
                what = "no item" if not hits else f"{len(hits)} items ({', '.join(f'[{i}]' for i in hits)})"
                raise ValueError(f"{what} of {where} named {str(part)!r}; names: {listed}")
            part = hits[0]
        out.append(part)
        if isinstance(node, dict) and isinstance(part, str):
            node = node.get(part)
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
        else:
            node = None
    return tuple(out)


def _set(src: Source, path: Path, value: Any, marks: dict[Path, Mark]) -> None:
    """Put ``value`` at ``path`` in ``src.data`` (creating mappings), re-pointing marks of the subtree."""
    node = src.data
    for i, part in enumerate(path[:-1]):
        nxt = path[i + 1]
        if isinstance(node, dict):
            if not isinstance(node.get(part), (dict, list)):
                node[part] = {} if isinstance(nxt, str) else []
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
        else:
            raise KeyError(dotted(path[: i + 1]))
    last = path[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or last >= len(node):
            raise KeyError(dotted(path))
    elif not isinstance(node, dict) or not isinstance(last, str):
        raise KeyError(dotted(path))
    node[last] = copy.deepcopy(value)
    for table in (src.values, src.keys):
        for p in [p for p in table if p[: len(path)] == path]:
            del table[p]
    for rel, mark in marks.items():
        src.values[path + rel] = mark
    src.keys[path] = marks.get((), src.mark(path))


def apply_sets(src: Source, sets: list[str], notes: list[str] | None = None) -> Source:
    """Apply ``--set key.path=value`` overrides (values parsed as YAML) to a loaded config. A list item is
    chosen by index or by name (``outputs[2].count=all``, ``outputs[frames].count=all``; see ``select``).

    Switching a plugin (``--set solver.name=baumgarte``) keeps the section's keys that the new plugin accepts
    and drops the others, each named in ``notes``: the old solver's ``iterations`` means nothing to a solver
    without them, and refusing the switch would make every comparison a hand edit of the file."""
    _check_mapping(src)  # the config's own error before any override's
    out = src.copy()
    for text in sets:
        key, eq, raw = text.partition("=")
        where = f"--set {text}"
        if not eq or not key.strip():
            raise ConfigError("expected key.path=value", file=where)
        try:
            path = select(out.data, parse_key(key.strip(), named=True))
        except ValueError as exc:
            raise ConfigError(str(exc), file=where) from None
        value = load_text(raw, where).data if raw.strip() else None
        mark = Mark(where, 1, len(key) + 2)
        try:
            _set(out, path, value, {(): mark})
        except KeyError as exc:
            blocked = _blocked(out, path)
            if blocked is not None:  # the config's own value is in the way: say where it is
                kind = {list: "a list", dict: "a mapping"}.get(type(_get_at(out.data, blocked)), "a single value")
                raise out.error(blocked, f"the config's value here is {kind}; {where} cannot reach inside it") \
                    from None
            raise ConfigError(f"no such place in the config: {exc.args[0]}", file=where) from None
        if path in _SWITCHES and isinstance(value, str):
            dropped = _keep_accepted(out, path[:-1], _SWITCHES[path], value, where)
            if dropped and notes is not None:
                notes.append(f"{where}: dropped {', '.join(dropped)} ({value!r} does not take them)")
    return out


def _get_at(data: Any, path: Path) -> Any:
    for part in path:
        data = data[part]
    return data


def _blocked(src: Source, path: Path) -> Path | None:
    """The first place on ``path`` whose value in the config is a scalar or list where a ``--set`` needs to go
    inside a mapping (or a list too short), if the config wrote it; else None."""
    node: Any = src.data
    for i, part in enumerate(path):
        ok = (isinstance(node, dict) and isinstance(part, str)) or \
             (isinstance(node, list) and isinstance(part, int) and part < len(node))
        if not ok:
            return path[:i] if i and path[:i] in src.values else None
        if isinstance(node, dict) and part not in node:
            return None
        node = node[part]
    return None


_SWITCHES: dict[Path, registry.Registry[Any]] = {("solver", "name"): registry.solvers,
                                                 ("scene", "name"): registry.scenes}


def _keep_accepted(src: Source, section: Path, reg: registry.Registry[Any], name: str, where: str) -> list[str]:
    """Drop the keys of ``section`` that plugin ``name`` does not accept; return them, in the file's order."""
    try:
        params = reg.get(name).Params
    except registry.UnknownName as exc:
        raise ConfigError(exc.hinted(above_hint(src.file)), file=where) from None
    except ConfigError as exc:
        raise ConfigError(exc.message, file=where) from None
    accepted = {f.alias or k for k, f in params.model_fields.items()} | set(params.model_fields) | {"name"}
    node = src.data
    for part in section:
        node = node[part]
    dropped = [k for k in node if k not in accepted]
    for k in dropped:
        del node[k]
        for table in (src.values, src.keys):
            for p in [p for p in table if p[: len(section) + 1] == (*section, k)]:
                del table[p]
    return dropped


# ---------------------------------------------------------------------------- pydantic errors, located


def _allowed(model: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """The keys a mapping at ``loc`` accepts, read from the model's JSON schema (best effort)."""
    schema = model.model_json_schema()
    defs = schema.get("$defs", {})
    node: dict[str, Any] = schema

    def deref(n: dict[str, Any]) -> dict[str, Any]:
        while "$ref" in n:
            n = defs[n["$ref"].split("/")[-1]]
        if "anyOf" in n:
            n = next((deref(a) for a in n["anyOf"] if "properties" in deref(a) or "items" in deref(a)), n)
        return n

    for part in loc:
        node = deref(node)
        if isinstance(part, int):
            node = node.get("items", {})
        else:
            node = node.get("properties", {}).get(part, {})
    return sorted(deref(node).get("properties", {}))


def located(exc: ValidationError, model: type[BaseModel], src: Source, prefix: Path) -> ConfigError:
    """Turn the first pydantic error into a one-line ``ConfigError`` at the offending key."""
    err = exc.errors(include_url=False)[0]
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-")))
    path = prefix + loc
    kind = err["type"]
    if kind == "extra_forbidden":
        allowed = _allowed(model, loc[:-1])
        msg = f"unknown key {loc[-1]!r}" + (f"; allowed: {', '.join(allowed)}" if allowed else "")
        return src.error(path, msg, key=True)
    if kind == "missing":
        return src.error(path[:-1], f"missing required key {loc[-1]!r}")
    msg = err["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    value = err.get("input")
    if isinstance(value, (int, float, str, bool)) and kind not in ("value_error", "assertion_error"):
        msg += f" (got {value!r})"
    return src.error(path, msg)


def validate_model(model: type[BaseModel], data: Any, src: Source, prefix: Path) -> Any:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise located(exc, model, src, prefix) from None


# ---------------------------------------------------------------------------- the experiment


def _plugin(reg: registry.Registry[Any], section: dict[str, Any], key: str, src: Source, prefix: Path) -> Any:
    """Look up ``section[key]`` in ``reg`` and validate the rest of the section with its params model."""
    name = section.get(key)
    if key in section and not isinstance(name, str):
        raise src.error(prefix + (key,), f"a {reg.kind} plugin's name is text, not {reprlib.repr(name)}")
    if not isinstance(name, str):
        raise src.error(prefix, f"missing {key!r}: the {reg.kind} plugin's name")
    try:
        cls = reg.get(name)
        registry.require_available(reg.kind, name, cls)
    except registry.UnknownName as exc:
        raise src.error(prefix + (key,), exc.hinted(above_hint(src.file))) from None
    except ConfigError as exc:
        raise src.error(prefix + (key,), exc.message) from None
    rest = {k: v for k, v in section.items() if k != key}
    return cls, validate_model(cls.Params, rest, src, prefix)


class _Override(NamedTuple):
    """One value a run overrides: the dotted key as written, its path, the value, where it is written, and the
    marks of the value's own keys and items (relative to it), so errors inside it point into the config."""

    key: str
    path: Path
    value: Any
    origin: Path
    marks: dict[Path, Mark]


def _override(src: Source, key: str, value: Any, origin: Path, key_origin: Path,
              marks: dict[Path, Mark]) -> _Override:
    """Check a per-run override key (refused at ``key_origin``) and bundle it with its value and ``marks``, those
    of the value's own keys and items (see ``_marks_below``)."""
    try:
        path = parse_key(key)
    except ValueError as exc:
        raise src.error(key_origin, str(exc), key=True) from None
    if path[0] not in RUN_KEYS:
        raise src.error(key_origin, f"only {', '.join(RUN_KEYS)} can be overridden per run", key=True)
    return _Override(key, path, value, origin, marks)


def _marks_below(src: Source, top: Path, depth: int) -> dict[Path, dict[Path, Mark]]:
    """The marks of every value ``depth`` levels below ``top`` (each run's overrides, each grid value) and of
    what is inside it, relative to it, by that value's path: one pass over the config's marks for all of them,
    where a pass for each would make checking ten thousand runs take minutes (their count times the config's
    values)."""
    out: dict[Path, dict[Path, Mark]] = {}
    at = len(top) + depth
    for path, mark in src.values.items():
        if len(path) >= at and path[: len(top)] == top:
            out.setdefault(path[:at], {})[path[at:]] = mark
    return out


def _variants(exp: ExperimentModel, src: Source) -> Iterator[tuple[str, Source, dict[str, Any]]]:
    """The runs of an experiment: (name, the run's part of the config with overrides applied, overrides), made
    one at a time. How many there are, named or a sweep's (known from its grid's shape), is checked against
    ``limits.max_runs`` before the first run is made."""
    if exp.runs is not None and exp.sweep is not None:
        raise src.error(("sweep",), "give either 'runs' or 'sweep', not both", key=True)
    if exp.runs is not None and len(exp.runs) > exp.limits.max_runs:
        raise src.error(("runs",), f"{len(exp.runs):,} named runs, over limits.max_runs = {exp.limits.max_runs:,}; "
                                   "name fewer, or raise the limit (limits: {max_runs: N})", key=True)
    if exp.sweep is not None:
        size = math.prod(len(values) for values in exp.sweep.grid.values())
        if size > exp.limits.max_runs:
            shape = " x ".join(str(len(values)) for values in exp.sweep.grid.values())
            raise src.error(("sweep", "grid"), f"the grid makes {shape} = {size:,} runs, over limits.max_runs = "
                                               f"{exp.limits.max_runs:,}; use fewer values, or raise the limit "
                                               "(limits: {max_runs: N})")
    base = _run_part(src)
    seen: set[str] = set()
    for name, sets in _plans(exp, src):
        if not NAME.match(name):
            raise src.error(("sweep", "name"), f"run name {name!r} is not letters, digits and _; change the template")
        if name in seen:
            raise src.error(("sweep", "name"), f"two runs are named {name!r}; put every grid key in the name")
        seen.add(name)
        variant = base.copy()
        for o in sets:
            try:
                _set(variant, o.path, o.value, o.marks)
            except KeyError as exc:
                raise src.error(o.origin, f"no such place in the config: {exc.args[0]}", key=True) from None
        yield name, variant, {o.key: o.value for o in sets}


def _plans(exp: ExperimentModel, src: Source) -> Iterator[tuple[str, tuple[_Override, ...]]]:
    """Each run's name and overrides, in order: the named ``runs``, the ``sweep``'s grid points (last key
    fastest), or the config's one run ``main``."""
    if exp.runs is not None:
        if not exp.runs:
            raise src.error(("runs",), "'runs' is empty")
        marks = _marks_below(src, ("runs",), 2)
        for name, sets in exp.runs.items():
            yield name, tuple(_override(src, k, v, ("runs", name, k), ("runs", name, k),
                                        marks.get(("runs", name, k), {})) for k, v in sets.items())
    elif exp.sweep is not None:
        options = []  # per grid key, one override per value: each key is checked once, not once per run
        marks = _marks_below(src, ("sweep", "grid"), 2)
        for k, values in exp.sweep.grid.items():
            key_origin = ("sweep", "grid", k)
            options.append([_override(src, k, v, (*key_origin, i), key_origin, marks.get((*key_origin, i), {}))
                            for i, v in enumerate(values)])
        for index, sets in enumerate(itertools.product(*options)):
            fill = {"index": str(index), **{o.key: _fmt(o.value) for o in sets}}
            try:
                name = re.sub(r"\{([^{}]+)\}", lambda m: fill[m.group(1)], exp.sweep.name)
            except KeyError as exc:
                raise src.error(("sweep", "name"), f"unknown field {{{exc.args[0]}}}; allowed: "
                                                   f"{', '.join('{' + k + '}' for k in fill)}") from None
            yield name, sets
    else:
        yield "main", ()


def _run_part(src: Source) -> Source:
    """The part of a config that a run is made of (``RUN_KEYS``, with their marks and the root's): all that a
    run's overrides change and ``_resolve_run`` reads. It is copied once per run, so it is kept small."""

    def kept(path: Path) -> bool:
        return not path or path[0] in RUN_KEYS

    return Source(src.file, {k: v for k, v in src.data.items() if k in RUN_KEYS},
                  {p: m for p, m in src.values.items() if kept(p)}, {p: m for p, m in src.keys.items() if kept(p)})


def _fmt(value: Any) -> str:
    text = repr(value) if isinstance(value, float) else str(value)
    return text.replace("-", "m").replace(".", "p")


def _resolve_run(name: str, src: Source, overrides: dict[str, Any], sections: dict[str, Any],
                 exp: ExperimentModel) -> RunSpec:
    """One run's spec. ``sections`` holds the scenes and solvers made so far by their section's text: runs of
    a sweep repeat most sections, and one validated once is shared (plugins never change their params). A
    run without overrides is the config's own, already validated as ``exp``."""
    base = exp if not overrides else validate_model(ExperimentModel, src.data, src, ())  # see _run_part
    if base.scene is None or base.solver is None:
        missing = "scene" if base.scene is None else "solver"
        raise src.error((missing,), f"a run needs a {missing!r} section")
    scene_key, solver_key = f"scene {base.scene!r}", f"solver {base.solver!r}"
    limits = exp.limits
    if scene_key not in sections:
        for key, value in base.scene.items():  # a listed scene is counted before its boxes are validated
            if isinstance(value, list) and len(value) > limits.max_bodies:
                raise src.error(("scene", key), _too_many_bodies(len(value), limits))
        scene_cls, scene_params = _plugin(registry.scenes, base.scene, "name", src, ("scene",))
        sections[scene_key] = scene = scene_cls(scene_params)
        if scene.size() > limits.max_bodies:
            sizing_key = next((p for p in src.values if p[:1] == ("scene",) and p[-1] in SIZE_KEYS), ("scene",))
            raise src.error(sizing_key, _too_many_bodies(scene.size(), limits))
    if solver_key not in sections:
        sections[solver_key] = _plugin(registry.solvers, base.solver, "name", src, ("solver",))
    scene, (solver_cls, solver_params) = sections[scene_key], sections[solver_key]
    try:
        model = registry.models.get(scene.model)
    except ConfigError as exc:
        raise src.error(("scene", "name"), f"scene {scene.plugin_name!r}: {exc.message}") from None
    if scene.model not in solver_cls.models:
        raise src.error(("solver", "name"), f"solver {solver_cls.plugin_name!r} steps {', '.join(solver_cls.models)}"
                                            f" scenes, not {scene.model!r} (scene {scene.plugin_name!r}); "
                                            f"solvers of {scene.model!r}: {', '.join(_stepping(scene.model))}")
    if base.steps == 0:
        raise src.error(("steps",), "a run needs 'steps' > 0")
    if base.steps * scene.size() > limits.max_box_steps:
        raise src.error(("steps",), f"run {name!r}: {base.steps:,} steps x {scene.size():,} boxes = "
                                    f"{base.steps * scene.size():.3g}, over limits.max_box_steps = "
                                    f"{limits.max_box_steps:g}; use fewer steps or boxes, or raise the limit "
                                    "(limits: {max_box_steps: N})")
    for event in scene.events():
        if event.step > base.steps - model.window:
            raise src.error(("scene", *event.origin, "step"), f"step {event.step} is too late: events happen "
                            f"before the last {model.window} of the {base.steps} steps, which measure the "
                            "final motion of one set of boxes")
    outlasted = scene.outlasts(base.steps, base.dt, base.gravity)
    if outlasted is not None:
        raise src.error(outlasted[0], f"run {name!r}: {outlasted[1]}")
    return RunSpec(name, scene, solver_cls, solver_params, base.gravity, base.dt, base.steps, overrides, model)


def _too_many_bodies(count: int, limits: Limits) -> str:
    return (f"the scene has {count:,} boxes, over limits.max_bodies = {limits.max_bodies:,}; use fewer, or raise "
            "the limit (limits: {max_bodies: N})")


def _stepping(model: str) -> list[str]:
    """Names of the built-in, installed and local solvers that step ``model`` (installed ones are loaded)."""
    names = []
    for entry in registry.solvers.entries():
        try:
            cls = registry.solvers.get(entry.name)
        except ConfigError:
            continue
        if model in getattr(cls, "models", ()):
            names.append(entry.name)
    return names or ["none"]


def _check_mapping(src: Source) -> None:
    if not isinstance(src.data, dict):
        raise src.error((), "a config is a mapping of keys (description, scene, solver, steps, outputs, ...)")


def build(src: Source) -> ExperimentSpec:
    """Validate a loaded config completely, without running anything."""
    _check_mapping(src)
    exp = validate_model(ExperimentModel, src.data, src, ())
    runs: list[RunSpec] = []
    if exp.scene is not None or exp.solver is not None or exp.runs or exp.sweep:
        sections: dict[str, Any] = {}
        runs = [_resolve_run(name, variant, sets, sections, exp) for name, variant, sets in _variants(exp, src)]
    outputs: list[Output] = []
    for i, section in enumerate(exp.outputs):
        kinds = [k for k in ("sink", "render") if k in section]
        if len(kinds) != 1:
            raise src.error(("outputs", i), "each output names exactly one of 'sink: NAME' or 'render: NAME'")
        reg = registry.sinks if kinds[0] == "sink" else registry.renderers
        cls, params = _plugin(reg, section, kinds[0], src, ("outputs", i))
        outputs.append(cls(params))
    spec = ExperimentSpec(src.file, FsPath(src.file).stem, exp.description, runs, exp.limits, outputs=outputs,
                          source=src, resolved=_resolved(exp, runs, outputs), bench=exp.bench)
    written: list[tuple[str, int]] = []
    drawn = 0  # pictures of every output so far: many renderers must not multiply past limits.max_frames
    for i, output in enumerate(outputs):
        prefix: Path = ("outputs", i)
        if output.needs_runs and not runs:
            raise src.error(prefix, f"{output.plugin_name!r} needs a simulation: add scene, solver and steps")
        other = next((r for r in runs if output.models is not None and r.scene.model not in output.models), None)
        if other is not None:
            drawn = list(output.models or ())
            names = " and ".join([", ".join(drawn[:-1]), drawn[-1]] if len(drawn) > 1 else drawn)
            raise src.error(prefix + (_kind(output),), f"{output.plugin_name!r} draws {names} scenes, not "
                            f"{other.scene.model!r} (run {other.name!r})")
        output.check(spec, lambda path, msg, prefix=prefix: src.error(prefix + path, msg))
        confine(output, lambda path, msg, prefix=prefix: src.error(prefix + path, msg))
        drawn += output.pictures()
        if drawn > exp.limits.max_frames:
            raise src.error(prefix, f"the outputs up to this one draw {drawn:,} pictures, over limits.max_frames = "
                            f"{exp.limits.max_frames:,} for the whole experiment; draw fewer frames or raise the "
                            "limit (limits: {max_frames: N})")
        written += [(name, i) for name in output.files()]
    clash = clashes(written)
    if clash is not None:
        name, i, earlier, j, why = clash
        other = src.mark(("outputs", j, path_key(outputs[j], earlier)))
        path = ("outputs", i, path_key(outputs[i], name))
        raise src.error(path, f"{why} outputs[{j}] (line {other.line}, column {other.col})")
    sizing.check(spec, lambda path, msg: src.error(path, msg))
    return spec


def _kind(output: Output) -> str:
    """The key that names an output's plugin: ``render`` or ``sink``."""
    return "render" if isinstance(output, Renderer) else "sink"


def _dump(params: BaseModel) -> dict[str, Any]:
    """Params as the config would spell them (aliases such as ``from``), defaults included."""
    return params.model_dump(mode="json", by_alias=True)


def _resolved(exp: ExperimentModel, runs: list[RunSpec], outputs: list[Output]) -> dict[str, Any]:
    """The config as it was run: ``--set`` applied, ``runs``/``sweep`` expanded into one entry per run, and
    every default filled in by the plugins' params models (what was simulated and what was written)."""
    return {
        "description": exp.description,
        "runs": [{"name": r.name, "scene": {"name": r.scene.plugin_name, **_dump(r.scene.params)},
                  "solver": {"name": r.solver_cls.plugin_name, **_dump(r.solver_params)},
                  "gravity": r.gravity, "dt": r.dt, "steps": r.steps} for r in runs],
        "outputs": [{_kind(o): o.plugin_name,
                     **_dump(o.params)} for o in outputs],
        "limits": _dump(exp.limits),
    }


def own_plugins(config: str) -> FsPath:
    """The ``plugins/`` folder in a config's own folder, whether it exists or not: the one folder loading the
    config imports from when ``--plugins`` names none. Folders above are never imported: a config in a shared
    or downloaded tree does not run code that someone left in a folder above it."""
    return FsPath(config).absolute().parent.resolve() / "plugins"


def plugins_above(config: str) -> FsPath | None:
    """The nearest ``plugins/`` folder above a config's own folder (None: none): never imported, only named
    when the config asks for a plugin nobody defines."""
    for folder in own_plugins(config).parent.parents:
        if (folder / "plugins").is_dir():
            return folder / "plugins"
    return None


def above_hint(config: str) -> str:
    """What to add to an unknown plugin name's error: a ``plugins/`` folder above the config, which was not
    imported, and how to name it (empty when there is none, or it was named with ``--plugins``)."""
    if not FsPath(config).is_file():
        return ""  # a config made from a dict (the Python API) has no folder
    above = plugins_above(config)
    if above is None or above in registry.plugin_folders():
        return ""
    try:
        shown = min(os.path.relpath(above), str(above), key=len)  # ../../plugins, not ../home/me/lab/plugins
    except ValueError:  # another drive
        shown = str(above)
    return f"; plugins/ folders above the config are not imported: name one with --plugins {shown};"


def local_plugins(plugins: FsPath | None, default: FsPath | None) -> FsPath | None:
    """Import the local plugins of ``--plugins DIR`` (refused when it is not a folder), else of ``default``
    when it is one; return the folder imported from (None: none)."""
    if plugins is not None and not plugins.is_dir():
        raise ConfigError("--plugins: no such folder", file=str(plugins))
    folder = plugins if plugins is not None else default
    if folder is None:
        return None
    registry.load_local_plugins(folder)  # also remembers an absent folder: outputs may not create it
    return folder if folder.is_dir() else None


def load(path: str, sets: list[str] | None = None, plugins: FsPath | None = None,
         notes: list[str] | None = None) -> ExperimentSpec:
    """Load, override and validate one config file; local plugins (``--plugins DIR``, else the ``plugins/``
    folder beside the config) come first. What an override changed beyond its own key (see ``apply_sets``) is
    added to ``notes``."""
    folder = local_plugins(plugins, own_plugins(path) if plugins is None else None)
    src = load_file(path)
    if sets:
        src = apply_sets(src, sets, notes)
    spec = build(src)
    spec.sets = list(sets or [])
    spec.plugins = str(folder.resolve()) if folder is not None else None
    return spec


def config_files(paths: list[str]) -> list[str]:
    """Expand the command line: a YAML file as is, a folder to the YAML files directly in it, in name order."""
    out: list[str] = []
    for p in paths:
        fp = FsPath(p)
        if fp.is_dir():
            found = sorted(str(f) for f in fp.iterdir() if f.suffix in (".yaml", ".yml") and f.is_file())
            if not found:
                raise ConfigError("no .yaml files in this folder", file=p)
            out.extend(found)
        elif fp.is_file():
            out.append(p)
        else:
            raise ConfigError("no such file or folder", file=p)
    return out
