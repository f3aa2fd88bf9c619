"""Compiled stepping: solver stages are plain Python loops, compiled by numba when that pays.

Every function a stepping loop calls is decorated with ``@kernel``, and a loop over independent batch rows
is written ``for b in prange(...)`` over the first argument's rows. The same source runs in one of two ways,
with the same numbers:

- **plain**: the readable Python it was written as (numpy arrays indexed element by element);
- **compiled**: numba ``njit`` with on-disk caching and no fastmath, so every operation rounds as in Python,
  and numpy's error model: a division by zero gives inf or NaN, as it does on the numpy scalars of the plain
  path, instead of a test before every division (a fifth of the lab step's time).
  A ``prange`` loop has two builds: a parallel one that spreads the rows over the cores
  (``NUMBA_NUM_THREADS`` caps the threads), used when the batch has ``GRAIN`` elements per thread, and a
  serial one for smaller batches, which would spend more on waking threads than they save. Rows are
  independent, so how they are split changes no number.

Which one runs is set by ``STACKX_JIT``: ``0`` plain, ``1`` compiled, ``auto`` (the default) compiled except
where the runner knows a batch is too small to pay for it. Importing numba and loading a column solver's cached
code costs about a second (a planar solver's several), a first compile a few seconds more (a planar one
minutes), and the plain path roughly 20 µs per box-step of a column solver at its default settings, so under
``auto`` a batch doing less work than ``STACKX_JIT_WORK`` (default 40,000) runs plain and does not import numba
at all: the whole lab then runs faster than numba can start.

The work is what the batch's steps do, not its size: the sum over its rows of steps x ``Solver.step_work``
(contact visits: passes + 1, times contacts), counted in box-steps at the solver's default passes
(``Solver.default_passes``: one solver's pass is not another's, a box-step at defaults costs about the same)
and times the model's ``step_cost`` (a planar body-step costs about a hundred column ones). A row making 40
times the passes of its solver's defaults is 40 times the work: counting boxes x steps once left a plugin making
400 passes a step on 20 boxes plain, 300 times slower than compiled. A solver that sets its passes only when it
steps is seen by the runner stepping a copy once before deciding. A Dask chunk is decided on the work of its
whole batch: a worker loads numba once and steps many chunks. A batch ``auto`` still left plain that stepped
``REGRET_SECONDS`` or more says so in one line naming ``STACKX_JIT=1`` (``regrets_plain``).

A small function that a pass calls for every contact point and that makes no array is marked ``@leaf``
instead: compiled without reference counting, a call passing it arrays costs what its arithmetic does. A
leaf too large for LLVM to inline is marked ``@inlined``: numba copies it into each caller (``inline``).

Compilation is lazy: ``@kernel`` wraps the function, and nothing is compiled until a compiled call is made.
The compiled version of a kernel is built from the same code with every kernel it names replaced by that
kernel's compiled version, so kernels must name each other as module globals (``from stackx.solvers.correct
import correct``), not as attributes of a module, and read module constants as numba does: once.

Compiled code is cached under ``STACKX_CACHE_DIR`` (default ``$XDG_CACHE_HOME/stackx``, else
``~/.cache/stackx``; numba falls back to its own places when that is not writable), which works the same
for an installed package and a clone. Each build's folder is named by a hash of its flags, its module, its source file
and those of the kernels it calls, and the values of the module constants they read: numba itself checks only
the function's own file and keys a build by its signature alone, so a change to ``correct`` or ``observe``, or
to a column number imported from another file, would otherwise leave every solver loading stale code, and a
parallel build could be loaded where the serial one was asked for.

Parallel builds run on numba's ``workqueue`` threads unless ``NUMBA_THREADING_LAYER`` names another layer:
OpenMP threads spin at the end of every parallel call, and on a machine with more busy processes than
cores that made a one-step call of a 2,000-row batch take 15 ms instead of 0.4 ms. The workqueue layer
serves one Python thread at a time, as stackx steps.
"""

from __future__ import annotations

import functools
import hashlib
import os
import threading
import types
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Any, Generic, ParamSpec, TypeVar

P = ParamSpec("P")
R = TypeVar("R")

PLAIN, COMPILED, AUTO = "0", "1", "auto"
DEFAULT_WORK = 40_000  # work (box-steps at a solver's default passes) from which compiling beats the plain path
# when the cache is warm: some 0.8 s of plain Python
REGRET_SECONDS = 5.0  # plain stepping under auto past which compiled (a second or so to load, then about a
# hundredth of the time) would have been faster by a wide margin: a batch this long says so (``regrets_plain``)
THREADING_LAYER = "workqueue"  # unless NUMBA_THREADING_LAYER says otherwise: see the module doc
GRAIN = 256  # batch elements (rows x boxes) per thread below which a prange loop runs on one thread

_state = threading.local()


def prange(*args: int) -> range:
    """Loop over independent batch rows: ``range`` in the plain path, ``numba.prange`` when compiled."""
    return range(*args)


SETTINGS = ("STACKX_JIT", "STACKX_JIT_WORK")  # the variables that choose the path, as a task carries them


def _setting(name: str, default: str) -> str:
    """A setting from the enclosing ``settings()`` block of this thread, else from the environment."""
    given = getattr(_state, "settings", None)
    source = given if given is not None else os.environ
    return source.get(name) or default


@contextmanager
def _scoped(name: str, value: Any) -> Iterator[None]:
    """This thread's ``name`` set to ``value`` inside the block, and back to what it was after."""
    before = getattr(_state, name, None)
    setattr(_state, name, value)
    try:
        yield
    finally:
        setattr(_state, name, before)


def settings(values: dict[str, str | None]) -> AbstractContextManager[None]:
    """Read ``STACKX_JIT`` and ``STACKX_JIT_WORK`` from ``values`` (None: unset) in this thread inside the block,
    not from the environment: a Dask worker steps each task with its sender's settings."""
    return _scoped("settings", {k: v for k, v in values.items() if v is not None})


def mode() -> str:
    """``STACKX_JIT``: ``0`` (plain), ``1`` (compiled) or ``auto``."""
    value = _setting("STACKX_JIT", AUTO).strip().lower()
    return value if value in (PLAIN, COMPILED) else AUTO


def min_work() -> int:
    """The work (box-steps at a solver's default passes) from which ``auto`` compiles (``STACKX_JIT_WORK``)."""
    try:
        return max(0, int(_setting("STACKX_JIT_WORK", str(DEFAULT_WORK))))
    except ValueError:
        return DEFAULT_WORK


@functools.cache
def available() -> bool:
    """Whether numba can be imported (asked once: a failed import is not cheap, and it does not change)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def enabled() -> bool:
    """Whether kernels called outside a ``compiled()`` block run compiled (unless ``STACKX_JIT=0``)."""
    return mode() != PLAIN and available()


def worth_compiling(work: float) -> bool:
    """Whether a batch doing ``work`` (box-steps at its solver's default passes, see the module doc) should
    run compiled, by ``STACKX_JIT``."""
    if mode() == AUTO and work < min_work():
        return False
    return enabled()


def regrets_plain(seconds: float) -> bool:
    """Whether a batch that ``auto`` stepped plain for ``seconds`` would by a wide margin have been faster
    compiled: ``REGRET_SECONDS`` or more of plain stepping, numba at hand. A plain path the user chose
    (``STACKX_JIT=0``) is not second-guessed."""
    return seconds >= REGRET_SECONDS and mode() == AUTO and available()


def compiled(on: bool) -> AbstractContextManager[None]:
    """Run the kernels called from Python inside the block compiled (``on``) or plain."""
    return _scoped("compiled", on)


def threads(most: int) -> AbstractContextManager[None]:
    """Run parallel kernels called inside the block (from this Python thread) on at most ``most`` threads. A
    Dask worker steps one task per thread it has, and a machine gets one such thread per core, so each task
    keeps to one core instead of every task waking a thread on every core."""
    return _scoped("threads", most)


class Kernel(Generic[P, R]):
    """A stepping function that runs plain or compiled: a call from Python takes the path of the enclosing
    ``compiled()`` block, or ``enabled()`` outside one."""

    def __init__(self, fn: Callable[P, R], counted: bool = True, inline: bool = False) -> None:
        self.py_func = fn
        self.counted = counted
        self.inline = inline
        self.parallel = any(fn.__globals__.get(name) is prange for name in fn.__code__.co_names)
        self.sources = {fn.__code__.co_filename}  # and, once compiled, the files of the kernels it calls
        self.constants = frozen(fn)  # and, once compiled, those of the kernels it calls
        self._plain: Callable[P, R] | None = None
        self._builds: dict[bool, Any] = {}
        functools.update_wrapper(self, fn)

    def __call__(self, *args: P.args, **kwargs: P.kwargs) -> R:
        on = getattr(_state, "compiled", None)
        if on is None:
            on = enabled()
        if on and not self.parallel:  # the serial build, once made (the reference calls kernels millions of times)
            serial = self._builds.get(False)
            if serial is not None:
                return serial(*args, **kwargs)  # type: ignore[no-any-return]
        return (self.compiled_for(args) if on else self.plain)(*args, **kwargs)  # type: ignore[no-any-return]

    def __repr__(self) -> str:
        return f"<kernel {self.__module__}.{self.__qualname__}>"

    @property
    def plain(self) -> Callable[P, R]:
        """The Python function, calling the plain versions of the kernels it names directly."""
        if self._plain is None:
            self._plain = self._twin({name: k.plain for name, k in self._callees().items()})
        return self._plain

    def compiled_for(self, args: tuple[Any, ...]) -> Any:
        """The compiled build for a call. A ``prange`` loop runs the parallel build when its first argument
        (the batch, rows first) has at least ``GRAIN`` elements per thread, on at most one thread per row;
        a smaller batch runs the serial build, which wakes no threads: a parallel region waits for every
        thread it uses, which costs microseconds on an idle machine and milliseconds on a busy one. Inside a
        ``threads(n)`` block a batch uses at most ``n`` threads."""
        if self.parallel and args:
            threads = spread(args[0])
            if threads > 1:
                import numba

                build = self.build(parallel=True)  # before the threads start: it picks their layer
                numba.set_num_threads(threads)
                return build
        return self.build(parallel=False)

    def build(self, parallel: bool = False) -> Any:
        """The numba dispatcher of the same code, calling the compiled kernels it names (made on first use)."""
        if parallel not in self._builds:
            import numba

            names: dict[str, Any] = {}
            for name, k in self._callees().items():
                names[name] = k.build()
                self.sources |= k.sources
                self.constants |= k.constants
            for name in self.py_func.__code__.co_names:
                if self.py_func.__globals__.get(name) is prange:
                    names[name] = numba.prange if parallel else range
            if parallel and not os.environ.get("NUMBA_THREADING_LAYER"):
                numba.config.THREADING_LAYER = THREADING_LAYER
            flags = {"cache": True, "fastmath": False, "error_model": "numpy", "parallel": parallel}
            if not self.counted:
                flags["_nrt"] = False
            if self.inline:
                flags["inline"] = "always"
            # numba's cached code names the module it was compiled in and imports it when loaded: a file
            # imported under another module name (a local plugin) needs a build of its own
            with _cache_dir(numba, self.sources, {**flags, "module": self.py_func.__module__,
                                                  "constants": sorted(self.constants)}):
                self._builds[parallel] = numba.njit(**flags)(self._twin(names))
        return self._builds[parallel]

    def _callees(self) -> dict[str, Kernel[Any, Any]]:
        """The kernels this one names, by the global name it uses."""
        fn = self.py_func
        return {name: value for name in fn.__code__.co_names
                if isinstance(value := fn.__globals__.get(name), Kernel) and value is not self}

    def _twin(self, names: dict[str, Any]) -> Callable[P, R]:
        """The same code with some globals replaced (a snapshot of the module's globals, as numba takes)."""
        fn = self.py_func
        twin = types.FunctionType(fn.__code__, {**fn.__globals__, **names}, fn.__name__, fn.__defaults__,
                                  fn.__closure__)
        twin.__qualname__, twin.__doc__ = fn.__qualname__, fn.__doc__
        return twin  # type: ignore[return-value]


def spread(batch: Any) -> int:
    """The threads a compiled ``prange`` kernel called from this thread on ``batch`` (rows first) runs on: one
    a row at most, ``GRAIN`` elements a thread at least, no more than numba has or a ``threads()`` block
    allows; 1 when numba is not there."""
    if not available():
        return 1
    import numba

    rows, size = (batch.shape[0], batch.size) if getattr(batch, "ndim", 0) else (1, 1)
    most = getattr(_state, "threads", None) or numba.config.NUMBA_NUM_THREADS
    return max(1, min(numba.config.NUMBA_NUM_THREADS, most, int(rows), int(size) // GRAIN))


def kernel(fn: Callable[P, R]) -> Kernel[P, R]:
    """Mark a stepping function: plain Python, or compiled with the kernels it calls (see the module doc)."""
    return Kernel(fn)


def leaf(fn: Callable[P, R]) -> Kernel[P, R]:
    """A kernel that makes no array and returns none, only reads and writes the ones it is given (a contact's
    relative velocity, an impulse applied at a point): compiled without numba's reference counting. A
    compiled call that passes arrays otherwise counts a reference to each on the way in and out, which
    costs more than the few multiplications such a function does (about 40 ns a call with five arrays,
    twenty times its arithmetic), and a pass over a pile's contact points makes several calls a point.
    Same code, same numbers; a leaf that tried to make an array would fail to compile."""
    return Kernel(fn, counted=False)


def inlined(fn: Callable[P, R]) -> Kernel[P, R]:
    """A ``leaf`` that numba copies into every compiled kernel calling it instead of calling it. LLVM inlines
    small leaves by itself; one too large for that (a two-point manifold's block solve, with the velocities
    and impulses it inlines in turn) is called, and the call passes its twenty arguments and its result
    through memory, which on a pass over a pile costs a tenth of the pass. Same code, same numbers."""
    return Kernel(fn, counted=False, inline=True)


def frozen(fn: Callable[..., Any]) -> set[str]:
    """The module constants ``fn`` reads, each as ``module.name=value``: numba compiles their values into the
    code, so a constant imported from another file (a table's column numbers) must key the cache as its
    file would. Numbers, strings and tuples of them by their repr (which is the same in every process);
    arrays by a hash of their bytes."""
    import numpy as np

    def plain(value: Any) -> bool:
        return isinstance(value, (bool, int, float, complex, str, np.generic)) or (
            isinstance(value, tuple) and all(plain(v) for v in value))

    out = set()
    for name in fn.__code__.co_names:
        value = fn.__globals__.get(name)
        if plain(value):
            shown = repr(value)
        elif isinstance(value, np.ndarray):
            shown = f"{value.dtype}{value.shape}:{hashlib.sha1(value.tobytes()).hexdigest()}"
        else:
            continue
        out.add(f"{fn.__module__}.{name}={shown}")
    return out


def cache_root() -> Path:
    """Where compiled code is kept: ``STACKX_CACHE_DIR``, else the user's cache folder."""
    if os.environ.get("STACKX_CACHE_DIR"):
        return Path(os.environ["STACKX_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "stackx"


def source_key(files: set[str], flags: dict[str, Any]) -> str:
    """A hash of the source files a compiled kernel is made of and of the flags it is compiled with (numba
    keys its cache by signature only, so a parallel and a serial build of one function would swap)."""
    digest = hashlib.sha1(repr(sorted(flags.items())).encode())
    for name in sorted(files):
        try:
            text = Path(name).read_bytes()
        except OSError:
            text = b""
        digest.update(name.encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


@contextmanager
def _cache_dir(numba: Any, files: set[str], flags: dict[str, Any]) -> Iterator[None]:
    """Point numba's cache at the folder of this build while its dispatcher is made (numba reads it then)."""
    before = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_root() / f"numba-{numba.__version__}" / source_key(files, flags))
    try:
        yield
    finally:
        numba.config.CACHE_DIR = before
