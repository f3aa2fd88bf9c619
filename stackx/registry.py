"""One registry per plugin kind: models, scenes, solvers, renderers and sinks.

A plugin comes from one of three places, and the registry remembers which so that ``stackx plugins`` and
every error can say so:
- built in: modules of this package register with a decorator, ``@solvers.register("pgs")``;
- installed: a distribution publishes an entry point in the group ``stackx.<kind>s``; only its name is read
  until the plugin is first used, so listing plugins imports nothing;
- local: every ``*.py`` file in one ``plugins/`` folder (in the config's own folder, or given with
  ``--plugins``; never one above) is imported before names are resolved, and registers itself with the same
  decorator. A folder or file that someone else could have put there is refused before anything in it runs:
  a link leading out of the folder, anything writable by every user, or owned by a user other than the one
  running (or root). ``imported_line`` names the files a command imported, for it to print.
Two plugins of one kind may not share a name: the second is refused, naming both sources.

A local file that fails to import does not stop configs that do not need it: the failure is recorded with
the names the file declares (read from its ``register("...")`` calls without running it), and it is raised
only when a config names one of those, or names a plugin nobody defines while some failed file could not be
read at all. ``get`` also checks, once per plugin, that it has what its kind needs (a ``Params`` model and
the methods the runner calls), so a half-written plugin fails at config load naming itself and its file.

A local file is imported as the module ``stackx_local_plugins.<stem>_<hash of its path and bytes>``, a name
that any process gives the same file, so its classes pickle by name: a Dask worker imports the same files
under the same names (``import_local``) before it unpickles the runs it is sent.
"""

from __future__ import annotations

import ast
import contextlib
import difflib
import errno
import hashlib
import importlib
import importlib.util
import os
import re
import stat
import sys
import traceback
import types
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
    "solver": ["stackx.solvers.column.pgs", "stackx.solvers.column.warm_start", "stackx.solvers.column.exact",
               "stackx.solvers.column.baumgarte", "stackx.solvers.column.split_impulse",
               "stackx.solvers.column.ngs", "stackx.solvers.column.soft_step",
               "stackx.solvers.column.xpbd", "stackx.solvers.column.jacobi",
               "stackx.solvers.planar.pgs", "stackx.solvers.planar.warm_start", "stackx.solvers.planar.ngs",
               "stackx.solvers.planar.exact", "stackx.solvers.planar.soft_step", "stackx.solvers.planar.xpbd",
               "stackx.solvers.column.avbd", "stackx.solvers.planar.avbd", "stackx.solvers.planar.jacobi",
               "stackx.solvers.planar.pgs_soft", "stackx.solvers.planar.tgs_soft",
               "stackx.solvers.planar.tgs_sticky", "stackx.solvers.planar.tgs_ngs", "stackx.solvers.planar.shock",
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


class UnknownName(ConfigError):
    """A plugin name no registry knows: what it is (``head``, with the closest known name) and what is known
    (``tail``), so that the config loader can say between them where else it could be defined (``hinted``),
    before the long list of known names."""

    def __init__(self, head: str, tail: str) -> None:
        super().__init__(head + tail)
        self.head, self.tail = head, tail

    def hinted(self, hint: str) -> str:
        """The message with ``hint`` (``"; ..."``, or empty) after what is unknown."""
        return self.head + hint + self.tail


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
            raise UnknownName(f"unknown {self.kind} {name!r}{hint}", f" known: {listing}{unread}")
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
LOCAL_PACKAGE = "stackx_local_plugins"  # the package local plugin files are imported into

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


def _declared(path: Path, source: bytes) -> dict[str, set[str]] | None:
    """``{kind: names}`` from the ``<registry>.register("name")`` calls in a file's ``source``, read without
    running it."""
    try:
        tree = ast.parse(source.decode("utf-8"), str(path))
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


_searched: list[Path] = []  # every plugin folder looked at in this process (imported from, or absent), absolute
_imported: list[tuple[Path, str]] = []  # (absolute folder, file name) of every local file run, in import order

_OPEN_FLAGS = (os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
               | getattr(os, "O_CLOEXEC", 0))
"""How a plugin folder and its files are opened: never through a link (a link is refused, or followed only
within its folder, by name), and a FIFO planted under a ``.py`` name is not waited on."""


def plugin_folders() -> list[Path]:
    """The plugin folders this process imports from or would (a config's own ``plugins/`` that does not exist
    yet included), absolute: what an output path must not write into."""
    return list(_searched)


def imported_count() -> int:
    """How many local plugin files this process has run: give it to ``imported_line`` to name those run after."""
    return len(_imported)


def imported_line(since: int = 0) -> str | None:
    """``plugins: imported sor.py, tall.py from /abs/plugins`` (folders separated by ``;``) naming every local
    plugin file this process ran after the first ``since``, or None when it ran none: one line a command prints
    on stderr."""
    folders: dict[Path, list[str]] = {}
    for folder, name in _imported[since:]:
        folders.setdefault(folder, []).append(name)
    if not folders:
        return None
    return "plugins: imported " + "; ".join(f"{', '.join(names)} from {folder}" for folder, names in folders.items())


def _absolute(folder: Path) -> Path:
    """``folder`` made absolute with the links of its parents resolved, its own last part kept as it is (a link
    there is the folder's own business: refused, not followed)."""
    folder = folder.absolute()
    return folder.parent.resolve() / folder.name


def _untrusted(st: os.stat_result, what: str) -> str | None:
    """Why a plugin folder or file with status ``st`` may hold code someone else wrote (None: it may not):
    writable by every user, or owned by a user other than the one running (root's own files are trusted)."""
    if st.st_mode & stat.S_IWOTH:
        return (f"{what} is writable by every user (mode {stat.S_IMODE(st.st_mode):04o}), so anyone may have put "
                "code there; not imported (chmod o-w it)")
    if st.st_uid not in (os.geteuid(), 0):
        return (f"{what} is owned by user {st.st_uid}, not by the user running stackx ({os.geteuid()}) or root; "
                "not imported")
    return None


def _open_folder(folder: Path) -> int | None:
    """A descriptor of the plugin folder, checked (None: there is none); a link or a folder someone else
    can change is refused."""
    try:
        fd = os.open(folder, _OPEN_FLAGS | getattr(os, "O_DIRECTORY", 0))
    except FileNotFoundError:
        return None
    except OSError as exc:
        if folder.is_symlink():
            raise ConfigError(f"the plugin folder is a link to {folder.resolve()}; not imported (name the real "
                              "folder with --plugins)", file=str(folder)) from None
        if exc.errno == errno.ENOTDIR:
            return None
        raise ConfigError(f"cannot read the plugin folder: {exc.strerror}", file=str(folder)) from None
    why = _untrusted(os.fstat(fd), "the plugin folder")
    if why:
        os.close(fd)
        raise ConfigError(why, file=str(folder))
    return fd


def _read_plugin(folder: Path, real_folder: Path, name: str, dir_fd: int) -> tuple[str, bytes] | None:
    """The name of the file a plugin entry stands for (itself, or the file of its folder a link names) and its
    bytes, read through one descriptor that was checked: a regular file, not writable by others, ours. None for
    a folder that happens to end in ``.py``."""
    try:
        fd = os.open(name, _OPEN_FLAGS, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno != errno.ELOOP:
            raise
        target = (folder / name).resolve()
        if target.parent != real_folder:
            raise ConfigError(f"the plugin file is a link to {target}, outside its folder; not imported",
                              file=str(folder / name)) from None
        name = target.name
        fd = os.open(name, _OPEN_FLAGS, dir_fd=dir_fd)  # the resolved name: a link put there since fails (ELOOP)
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            return None
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError("the plugin file is not a regular file; not imported", file=str(folder / name))
        why = _untrusted(st, "the plugin file")
        if why:
            raise ConfigError(why, file=str(folder / name))
        with os.fdopen(os.dup(fd), "rb") as file:
            return name, file.read()
    finally:
        os.close(fd)


def load_local_plugins(folder: Path) -> None:
    """Import every ``*.py`` in ``folder`` (in name order) once, so that its plugins register themselves.

    The folder and each file are checked first, through the descriptors they are read from, and the bytes
    checked are the bytes run: a link leading out, or anything another user could have written, is refused
    (``ConfigError``) before any of it runs."""
    absolute = _absolute(folder)
    if absolute not in _searched:
        _searched.append(absolute)
    dir_fd = _open_folder(folder)
    if dir_fd is None:
        return
    try:
        for reg in ALL.values():
            reg._discover()  # built-ins first, so a local plugin reusing a built-in name is the one refused
        real_folder = absolute.resolve()
        names = sorted(n for n in os.listdir(dir_fd) if n.endswith(".py") and not n.startswith(("_", ".")))
        for entry in names:
            try:
                read = _read_plugin(folder, real_folder, entry, dir_fd)
            except OSError as exc:
                _failures.append(Failure(str(folder / entry), f"{type(exc).__name__}: {exc}", None))
                continue
            if read is not None:
                name, source = read
                _import_file(folder, folder / name, real_folder / name, source)
    finally:
        os.close(dir_fd)


def _import_file(folder: Path, path: Path, real: Path, source: bytes) -> None:
    """Run one checked plugin file (``source``, the bytes read from ``real``) once per process; a failure is
    recorded with the names it declares, not raised."""
    if real in _loaded_files:
        return
    _loaded_files.add(real)
    _imported.append((_absolute(folder), path.name))
    local = LocalModule(_module_name(real, source), str(path), str(real), source)
    with _importing(str(path)):
        try:
            _exec(local.name, real, source)
        except Exception as exc:
            names = _declared(real, source)
            for kind, reg in ALL.items():
                started = reg.forget(str(path))
                if names is not None:
                    names.setdefault(kind, set()).update(started)
            _failures.append(Failure(str(path), " ".join(_where(exc, real).split()), names))
        else:
            _local_modules[local.name] = local


@dataclass(frozen=True)
class LocalModule:
    """A local plugin file as this process imported it: what another process needs to import the same module
    under the same name (``import_local``), so that the classes it defines unpickle there."""

    name: str     # the module's name, ``stackx_local_plugins.<stem>_<hash>``
    origin: str   # the path as it was found (what its plugins' ``plugin_origin`` says)
    path: str     # the file, resolved
    source: bytes


_local_modules: dict[str, LocalModule] = {}


def local_modules() -> list[LocalModule]:
    """The local plugin files imported in this process, in import order."""
    return list(_local_modules.values())


def _module_name(real: Path, source: bytes) -> str:
    """The same name for the same file in every process: its stem, and a hash of its path and bytes."""
    digest = hashlib.sha1(str(real).encode() + b"\0" + source).hexdigest()[:12]
    stem = re.sub(r"\W", "_", real.stem)
    return f"{LOCAL_PACKAGE}.{stem}_{digest}"


def _exec(name: str, file: Path, source: bytes) -> None:
    """Import ``source``, the bytes of ``file``, as the module ``name`` inside the local plugins' package (made
    on first use). The bytes are the ones already read and checked: the file is not opened again."""
    if LOCAL_PACKAGE not in sys.modules:
        package = types.ModuleType(LOCAL_PACKAGE, "Local plugin files, imported by path.")
        package.__path__ = []  # a package: its modules import, and so unpickle, by name
        sys.modules[LOCAL_PACKAGE] = package
    spec = importlib.util.spec_from_file_location(name, file)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        exec(compile(source, str(file), "exec", dont_inherit=True), module.__dict__)  # noqa: S102 - the plugin
    except BaseException:
        sys.modules.pop(name, None)
        raise


def import_local(local: LocalModule, spare: Path) -> None:
    """Import a local plugin file of another process under its name, unless a module of that name (the same
    path and bytes) is here already: from its path when the file there has the same bytes, else from a copy
    of its source written under ``spare``. Its plugins are not kept in this process's registries (the objects
    sent here name their classes directly), so files of two senders may register the same names."""
    if local.name in sys.modules:
        return
    file = Path(local.path)
    try:
        same = file.read_bytes() == local.source
    except OSError:
        same = False
    if not same:
        file = spare / local.name.rpartition(".")[2] / Path(local.path).name
        if not (file.is_file() and file.read_bytes() == local.source):
            file.parent.mkdir(parents=True, exist_ok=True)
            part = file.with_name(f".{file.name}.{os.getpid()}.tmp")  # whole or absent for a worker beside
            part.write_bytes(local.source)
            os.replace(part, file)
    for reg in ALL.values():
        reg._discover()  # built-ins first: one the file imports is not taken for one of its plugins
    with _importing(local.origin):
        try:
            _exec(local.name, file, local.source)
        finally:
            for reg in ALL.values():
                reg.forget(local.origin)
