"""One registry per plugin kind: solvers, renderers, sinks and scenes.

A plugin comes from one of three places, and the registry remembers which so that ``stackx plugins`` and
every error can say so:
- built in: modules of this package register with a decorator, ``@solvers.register("pgs")``;
- installed: a distribution publishes an entry point in the group ``stackx.<kind>s``; only its name is read
  until the plugin is first used, so listing plugins imports nothing;
- local: every ``*.py`` file in a ``plugins/`` folder (beside the config, or given with ``--plugins``) is
  imported before names are resolved, and registers itself with the same decorator.
Two plugins of one kind may not share a name: the second is refused, naming both sources.
"""

from __future__ import annotations

import contextlib
import difflib
import importlib
import importlib.util
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any, Generic, TypeVar

from stackx.errors import ConfigError

T = TypeVar("T")

BUILTIN_MODULES = {
    "scene": ["stackx.scenes.column"],
    "solver": ["stackx.solvers.pgs"],
    "renderer": ["stackx.render.check", "stackx.render.stack", "stackx.render.frames"],
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
        entry = self._entries.get(name)
        if entry is None:
            known = sorted(self._entries)
            close = difflib.get_close_matches(name, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            listing = ", ".join(f"{n} ({self._entries[n].origin})" for n in known)
            raise ConfigError(f"unknown {self.kind} {name!r}{hint} known: {listing}")
        if entry.plugin is None and entry.entry_point is not None:
            with _importing(entry.origin):
                try:
                    loaded = entry.entry_point.load()
                except Exception as exc:  # a third-party plugin that fails to import
                    raise ConfigError(f"{self.kind} {name!r} from {entry.origin} failed to load: {exc}") from None
            entry.plugin = entry.plugin or loaded
        assert entry.plugin is not None
        return entry.plugin


scenes: Registry[Any] = Registry("scene")
solvers: Registry[Any] = Registry("solver")
renderers: Registry[Any] = Registry("renderer")
sinks: Registry[Any] = Registry("sink")
ALL = {"scene": scenes, "solver": solvers, "renderer": renderers, "sink": sinks}

_loaded_files: set[Path] = set()


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
            except ConfigError:
                raise
            except Exception as exc:
                raise ConfigError(f"local plugin failed to import: {type(exc).__name__}: {exc}",
                                  file=str(path)) from None
