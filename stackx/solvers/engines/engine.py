"""What every engine solver shares: finding the engine, one world per batch row, reading the state back.

An engine steps the models it declares (``models``: the column and the planar model), with one world class per
model (``column``, ``planar``). An engine keeps its own bodies and stackx keeps the state, so every step goes the
same way: each batch row's world is stepped by one call into the engine (an engine bound to Python cannot be
asked for many steps and still be looked at after each), the bodies' coordinates are copied into the row's
arrays, and then the model's monitors are updated for every row. Every measure and criterion is therefore
computed by stackx from those positions, the same way as for its own solvers; nothing is taken from the
engine's own reports (contacts, impulses, sleeping flags). The column's mapping is described here, the planar
model's in ``stackx.solvers.engines.planar``.

On the column, the heights and vertical velocities go into ``y`` and ``v`` and the column's monitors
(``stackx.models.column.monitor.observe``) run.

The worlds are built from the state the first time it is advanced (a solver is made before the state it
steps): bottom box first, with the column's heights, velocities, masses and half-heights, gravity and the
row's ``dt``. A box that a scene event takes away (``remove_box``) goes from each world as the engine removes
bodies, and whatever the engine remembers of its contacts follows as the engine decides. The column moves
vertically only; how each engine is held to that (an infinite moment of inertia, fixed rotation, a slide
joint) is said in its module. Boxes are ``WIDTH`` wide in the engine's horizontal directions: with rotation
locked and friction off, the width only places the contact points of a face. The floor is a static box whose
top face is the line y = 0, ``FLOOR_WIDTH`` wide and ``FLOOR_DEPTH`` deep, or the engine's own infinite plane.

The engine's knobs (its params and how a world is set up) are apart from each model's mapping (``column``,
``planar``: the classes that put a model's bodies into a world), so another model joins as another such class
beside them, named in ``models``.

The engine's package is imported only when a solver is made, never when stackx or its plugin list is loaded.
``unavailable()`` says, without importing it, why an engine cannot run here (its package is not installed)
and the command that installs it: ``stackx plugins`` shows it, a config naming the engine stops at load with
that line (exit code 2), and ``stackx bench`` leaves the engine out unless it is named.
"""

from __future__ import annotations

import importlib
import importlib.util
import warnings
from types import ModuleType
from typing import Any, ClassVar, Protocol

import numpy as np

from stackx.errors import ConfigError
from stackx.kernel import kernel
from stackx.models.column.monitor import observe
from stackx.solvers.base import Solver
from stackx.models.column.state import ColumnState
from stackx.models.planar.state import PlanarState
from stackx.solvers.engines.planar import Boxes, PlanarWorld, advance_planar

WIDTH = 1.0  # horizontal size of every box in the engines (m)
FLOOR_WIDTH = 100.0  # horizontal size of the floor box (m)
FLOOR_DEPTH = 1.0  # thickness of the floor box under y = 0 (m)
EXTRA = "engines"  # the optional dependency group of stackx that installs every engine


@kernel
def observe_rows(y: np.ndarray, half: np.ndarray, dt: np.ndarray, last: np.ndarray, peak: np.ndarray,
                 reach: np.ndarray, touched: np.ndarray, launch: np.ndarray) -> None:
    """The column's monitors after a step of every batch row, from the heights the engines left.

    The rows are looped serially, not with ``prange``: the engines step their rows one after another in Python,
    and this runs once per step, where picking and waking threads would cost more than the loop itself."""
    for b in range(y.shape[0]):
        observe(y[b], half[b], dt[b], last, peak, reach, touched, launch, b)


class World(Protocol):
    """One batch row in an engine: its bodies, bottom box first."""

    def step(self) -> None:
        """Advance the engine by one of the column's steps (one call into the engine)."""

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        """Copy the bodies' heights and vertical velocities into the row's arrays, bottom box first."""

    def remove(self, box: int) -> None:
        """Take box ``box`` (among those left, bottom first) out of the world."""


class Engine(Solver):
    """Base of the engine solvers: a subclass names its package and builds one ``World`` per batch row."""

    models = ("column", "planar")
    column: ClassVar[type]  # its World for the column: made with (engine, params, g, dt, y, v, mass, half)
    planar: ClassVar[type]  # its PlanarWorld: made with (engine, params, g, dt, Boxes)
    package: ClassVar[str]  # the module the engine is imported as, e.g. "Box2D"
    distribution: ClassVar[str]  # the name pip installs it by, e.g. "box2d"
    one_step_per_call: ClassVar[bool] = True  # stackx.bench.timing times it one step per call only
    bench_by_default: ClassVar[bool] = False  # stackx bench runs it when named in --solvers

    def __init__(self, params: list[Any], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.engine = self.load()
        self.worlds: list[World] | list[PlanarWorld] | None = None

    @classmethod
    def install(cls) -> str:
        """The command that installs this engine."""
        return f"pip install 'stackx[{EXTRA}]' (or: pip install {cls.distribution})"

    @classmethod
    def unavailable(cls) -> str | None:
        """Why this engine cannot run here, with the command that installs it; None when its package is
        installed. Looks the package up without importing it."""
        try:
            found = importlib.util.find_spec(cls.package) is not None
        except (ImportError, ValueError):
            found = False
        if found:
            return None
        return (f"needs the Python package {cls.distribution!r}, which is not installed; "
                f"install it with: {cls.install()}")

    @classmethod
    def load(cls) -> ModuleType:
        """The engine's package, imported now; a missing or broken one is a one-line ``ConfigError``."""
        try:
            with warnings.catch_warnings():  # SWIG-made bindings (pybox2d) warn about their own types on import
                warnings.simplefilter("ignore", DeprecationWarning)
                return importlib.import_module(cls.package)
        except ImportError as exc:
            raise ConfigError(f"solver {cls.plugin_name!r} cannot import {cls.package!r} ({exc}); "
                              f"install it with: {cls.install()}") from None

    def world(self, b: int, y: np.ndarray, v: np.ndarray, mass: np.ndarray, half: np.ndarray) -> World:
        """The world of batch row ``b`` holding the column's boxes (heights, velocities, masses, half-heights):
        the engine's ``column`` class, given the engine's module, the row's params, gravity and dt."""
        return self.column(self.engine, self.params[b], float(self.gravity[b]), float(self.dt[b]), y, v, mass, half)

    def planar_world(self, b: int, boxes: Boxes) -> PlanarWorld:
        """The world of batch row ``b`` holding the planar row ``boxes``: the engine's ``planar`` class."""
        return self.planar(self.engine, self.params[b], float(self.gravity[b]), float(self.dt[b]), boxes)

    def advance(self, state: ColumnState | PlanarState, steps: int) -> None:
        """``steps`` steps of every row: one engine call per row and step, the positions and velocities read
        back into the state, then the monitors of every row. The worlds are built on the first call."""
        if isinstance(state, PlanarState):
            if self.worlds is None:
                self.worlds = [self.planar_world(b, Boxes.of(state, b)) for b in range(state.batch)]
            advance_planar(self.worlds, state, self.dt, steps)  # type: ignore[arg-type]
            return
        if self.worlds is None:
            self.worlds = [self.world(b, state.y[b].copy(), state.v[b].copy(), 1.0 / state.inv_mass[b],
                                      state.half[b].copy()) for b in range(state.batch)]
        rows = [(w.step, w.read, state.y[b], state.v[b]) for b, w in enumerate(self.worlds)]
        monitors = state.monitors()
        for _ in range(steps):
            for step, read, y, v in rows:
                step()
                read(y, v)
            observe_rows(state.y, state.half, self.dt, *monitors)

    def remove_box(self, state: ColumnState, box: int) -> None:
        for w in self.worlds or ():
            w.remove(box)

    def __copy__(self) -> Engine:
        """A twin that builds worlds of its own from the state it is first given: an engine's world cannot be
        copied in general, so a replay from a saved state (``stackx.run.watch``) starts without the contact memory
        the original had at that point."""
        twin = object.__new__(type(self))
        twin.__dict__.update(self.__dict__)
        twin.worlds = None
        return twin
