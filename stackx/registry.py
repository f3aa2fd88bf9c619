"""One registry per plugin kind: models, scenes, solvers, renderers and sinks.

A plugin comes from one of three places, and the registry remembers which so that ``stackx plugins`` and
every error can say so:
- built in: modules of this package register with a decorator, ``@solvers.register("pgs")``;
- installed: a distribution publishes an entry point in the group ``stackx.<kind>s``; only its name is read
  until the plugin is first used, so listing plugins imports nothing;
- local: every ``*.py`` file in a ``plugins/`` folder (beside the config, or given with ``--plugins``) is
  imported before names are resolved, and registers itself with the same decorator.
Two plugins of one kind may not share a name: the second is refused, naming both sources.

A local file that fails to import does not stop configs that do not need it: the failure is recorded with
the names the file declares (read from its ``register("...")`` calls without running it), and it is raised
only when a config names one of those, or names a plugin nobody defines while some failed file could not be
read at all. ``get`` also checks, once per plugin, that it has what its kind needs (a ``Params`` model and
the methods the runner calls), so a half-written plugin fails at config load naming itself and its file.
"""

from __future__ import annotations

import ast
import contextlib
import difflib
import importlib
import importlib.util
import sys
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any, Generic, TypeVar

from stackx.errors import ConfigError

T = TypeVar("T")

BUILTIN_MODULES = {
    "model": ["stackx.models.column.model", "stackx.models.planar.model"],
    "scene": ["stackx.scenes.column", "stackx.scenes.planar"],
    "solver": ["stackx.solvers.pgs", "stackx.solvers.warm_start", "stackx.solvers.exact",
               "stackx.solvers.baumgarte", "stackx.solvers.split_impulse",
               "stackx.solvers.ngs", "stackx.solvers.soft_step",
               "stackx.solvers.xpbd", "stackx.solvers.jacobi",
               "stackx.solvers.planar.pgs", "stackx.solvers.planar.warm_start", "stackx.solvers.planar.ngs",
               "stackx.solvers.planar.exact", "stackx.solvers.planar.soft_step", "stackx.solvers.planar.xpbd",
               # engines: their packages are imported only when a run is set up (stackx.solvers.engines.engine)
               "stackx.solvers.engines.pymunk_engine", "stackx.solvers.engines.box2d_engine",
               "stackx.solvers.engines.box2d3_engine", "stackx.solvers.engines.mujoco_engine"],
    "renderer": ["stackx.render.check", "stackx.render.stack", "stackx.render.frames",
                 "stackx.render.compare"],
    "sink": ["stackx.sinks.keyvalue", "stackx.sinks.metrics"],
}

_origin: list[str] = []  # the source being imported right now (local file or entry point), innermost last


@contextlib.contextmanager
def _importing(origin: str) -> Iterator[None]:
    _origin.append(origin)
    try:
        yield
    finally:
        _origin.pop()


@dataclass
class Entry(Generic[T]):
    """A registered name: where it came from, and the plugin once it is loaded."""

    name: str
    origin: str
    plugin: T | None = None
    entry_point: EntryPoint | None = None


class Registry(Generic[T]):
    """Plugins of one kind, by name."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self.group = f"stackx.{kind}s"
        self._entries: dict[str, Entry[T]] = {}
        self._discovered = False
        self._checked: set[str] = set()

    def register(self, name: str) -> Callable[[T], T]:
        """Class decorator that adds a plugin under ``name``; the module's origin is recorded."""

        def add(plugin: T) -> T:
            origin = _origin[-1] if _origin else "built-in"
            old = self._entries.get(name)
            if old is not None and old.entry_point is not None and old.plugin is None and origin == old.origin:
                old.plugin = plugin  # an entry point registering itself while being loaded
                return plugin
            if old is not None:
                raise ConfigError(f"{self.kind} {name!r} is defined twice: in {old.origin} and in {origin}")
            setattr(plugin, "plugin_name", name)
            setattr(plugin, "plugin_origin", origin)
            self._entries[name] = Entry(name, origin, plugin)
            return plugin

        return add

    def _discover(self) -> None:
        if self._discovered:
            return
        self._discovered = True
        for module in BUILTIN_MODULES.get(self.kind, []):
            importlib.import_module(module)
        for ep in entry_points(group=self.group):
            origin = f"entry point {ep.dist.name if ep.dist else ep.value}"
            old = self._entries.get(ep.name)
            if old is not None:
                raise ConfigError(f"{self.kind} {ep.name!r} is defined twice: in {old.origin} and in {origin}")
            self._entries[ep.name] = Entry(ep.name, origin, entry_point=ep)

    def entries(self) -> list[Entry[T]]:
        """Every known plugin of this kind, sorted by name; entry points are not imported."""
        self._discover()
        return sorted(self._entries.values(), key=lambda e: e.name)

    def get(self, name: str) -> T:
        """The plugin called ``name``; an unknown name lists what exists and suggests the closest."""
        self._discover()
        for failure in _failures:
            if failure.names is not None and name in failure.names.get(self.kind, ()):
                raise ConfigError(f"{self.kind} {name!r} is defined in {failure.file}, which failed to import: "
                                  f"{failure.message}")
        entry = self._entries.get(name)
        if entry is None:
            known = sorted(self._entries)
            close = difflib.get_close_matches(name, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            listing = ", ".join(f"{n} ({self._entries[n].origin})" for n in known)
            unread = "".join(f"; {f.file} failed to import ({f.message}) and may define it"
                             for f in _failures if f.names is None)
            raise ConfigError(f"unknown {self.kind} {name!r}{hint} known: {listing}{unread}")
        if entry.plugin is None and entry.entry_point is not None:
            with _importing(entry.origin):
                try:
                    loaded = entry.entry_point.load()
                except Exception as exc:  # a third-party plugin that fails to import
                    raise ConfigError(f"{self.kind} {name!r} from {entry.origin} failed to load: {exc}") from None
            if entry.plugin is None:  # an entry point naming a class that does not register itself
                for attr, value in (("plugin_name", name), ("plugin_origin", entry.origin)):
                    with contextlib.suppress(AttributeError, TypeError):
                        setattr(loaded, attr, value)
                entry.plugin = loaded
        assert entry.plugin is not None
        if name not in self._checked:
            _check_contract(self.kind, name, entry.origin, entry.plugin)
            self._checked.add(name)
        return entry.plugin

    def forget(self, origin: str) -> list[str]:
        """Drop every plugin registered from ``origin`` (a file that failed half-way); return their names."""
        names = [n for n, e in self._entries.items() if e.origin == origin]
        for n in names:
            del self._entries[n]
        return names


def unavailable(plugin: Any) -> str | None:
    """Why a plugin cannot run on this machine (an engine whose package is not installed, with the command that
    installs it), or None; read from its ``unavailable()`` classmethod, without importing anything."""
    check = getattr(plugin, "unavailable", None)
    return check() if callable(check) else None


def require_available(kind: str, name: str, plugin: Any) -> None:
    """Refuse a plugin that cannot run here, saying why and how to install what it needs."""
    why = unavailable(plugin)
    if why:
        raise ConfigError(f"{kind} {name!r} cannot run here: {why}")


models: Registry[Any] = Registry("model")
scenes: Registry[Any] = Registry("scene")
solvers: Registry[Any] = Registry("solver")
renderers: Registry[Any] = Registry("renderer")
sinks: Registry[Any] = Registry("sink")
ALL = {"model": models, "scene": scenes, "solver": solvers, "renderer": renderers, "sink": sinks}

_loaded_files: set[Path] = set()

# what each kind's plugins must be: (module, base class, methods the base leaves to the plugin)
CONTRACTS = {
    "model": ("stackx.models", "Model", ("measure", "state_measures", "offender", "motion")),
    "solver": ("stackx.solvers.base", "Solver", ("advance",)),
    "scene": ("stackx.scenes", "Scene", ("build",)),
    "renderer": ("stackx.outputs", "Renderer", ("write",)),
    "sink": ("stackx.outputs", "Sink", ("write",)),
}


def _check_contract(kind: str, name: str, origin: str, plugin: Any) -> None:
    """Refuse a plugin that cannot work: not a subclass of its kind's base, no ``Params``, a method missing."""
    from pydantic import BaseModel

    module, base_name, methods = CONTRACTS[kind]
    base = getattr(importlib.import_module(module), base_name)
    where = f"{kind} {name!r} from {origin}"
    if not (isinstance(plugin, type) and issubclass(plugin, base)):
        raise ConfigError(f"{where} is not a subclass of {module}.{base_name}")
    params = getattr(plugin, "Params", None)
    if not (isinstance(params, type) and issubclass(params, BaseModel)):
        raise ConfigError(f"{where} has no 'Params' (a pydantic model of its parameters)")
    missing = [m for m in methods if getattr(plugin, m, None) is getattr(base, m, None)]
    if missing:
        raise ConfigError(f"{where} does not define {', '.join(repr(m) for m in missing)}")


@dataclass
class Failure:
    """A local plugin file that failed to import, and the names it declares (None: the file is unreadable)."""

    file: str
    message: str
    names: dict[str, set[str]] | None


_failures: list[Failure] = []

_REGISTRY_NAMES = {f"{kind}s": kind for kind in ALL}  # the module globals above: solvers -> solver


def _declared(path: Path) -> dict[str, set[str]] | None:
    """``{kind: names}`` from the ``<registry>.register("name")`` calls in a file, read without running it."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    except (OSError, UnicodeDecodeError, SyntaxError, ValueError):
        return None
    out: dict[str, set[str]] = {}
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "register"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            target = node.func.value
            holder = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
            kinds = [_REGISTRY_NAMES[holder]] if holder in _REGISTRY_NAMES else list(_REGISTRY_NAMES.values())
            for kind in kinds:
                out.setdefault(kind, set()).add(node.args[0].value)
    return out


def _where(exc: BaseException, path: Path) -> str:
    """``line N: Type: message``, N being the last line of ``path`` the exception passed through."""
    line = exc.lineno if isinstance(exc, SyntaxError) and exc.filename == str(path) else None
    for frame in traceback.extract_tb(exc.__traceback__):
        if frame.filename == str(path):
            line = frame.lineno
    text = exc.message if isinstance(exc, ConfigError) else f"{type(exc).__name__}: {exc}"
    return f"line {line}: {text}" if line else text


def local_failures() -> list[Failure]:
    """Local plugin files that failed to import in this process."""
    return list(_failures)


def load_local_plugins(folder: Path) -> None:
    """Import every ``*.py`` in ``folder`` (in name order) once, so that its plugins register themselves."""
    if not folder.is_dir():
        return
    for reg in ALL.values():
        reg._discover()  # built-ins first, so a local plugin reusing a built-in name is the one refused
    for path in sorted(folder.glob("*.py")):
        real = path.resolve()
        if real in _loaded_files or path.name.startswith("_"):
            continue
        _loaded_files.add(real)
        module_name = f"stackx_local_plugins.{path.stem}_{len(_loaded_files)}"
        spec = importlib.util.spec_from_file_location(module_name, real)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module
        with _importing(str(path)):
            try:
                spec.loader.exec_module(module)
            except Exception as exc:
                sys.modules.pop(module_name, None)
                names = _declared(real)
                for kind, reg in ALL.items():
                    started = reg.forget(str(path))
                    if names is not None:
                        names.setdefault(kind, set()).update(started)
                _failures.append(Failure(str(path), " ".join(_where(exc, real).split()), names))
