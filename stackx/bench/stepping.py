"""How a solver steps, as a table says beside its time: compiled kernels, plain Python, or an engine.

A bench compiles every ``@kernel`` (``stackx.kernel``) it can, so the built-in solvers' times are those of
compiled loops. A plugin written as plain Python loops (no ``@kernel``) runs as written, some hundred times
slower per contact than a compiled loop: set beside compiled figures unmarked, its time reads as the cost of
its method instead of the cost of the language. An engine (pymunk, Box2D, MuJoCo) runs its own compiled code
one step per Python call. So every time a table shows carries how it was stepped.

Whether a solver reaches a kernel is read from its code, not from a run: its ``advance`` and what that calls
(its own methods, ``super().advance``, module functions) are followed until one of them names a ``Kernel``.
Reading code cannot see a kernel reached only through a value made at run time (a kernel stored in a dict
and looked up); such a solver reads as plain, which errs on the side of the mark.
"""

from __future__ import annotations

import types
from collections.abc import Iterator
from typing import Any

from stackx.kernel import Kernel

COMPILED, PLAIN, ENGINE = "compiled", "plain", "engine"
DEPTH = 6  # calls followed from advance before giving up on finding a kernel: deeper than any solver nests


def stepping(solver_cls: type, kernels_on: bool) -> str:
    """``engine`` for a solver stepped once per Python call (``one_step_per_call``), ``compiled`` for one whose
    ``advance`` reaches a kernel while compiled kernels are on (``kernels_on``: ``stackx.kernel.enabled()``),
    else ``plain``."""
    if getattr(solver_cls, "one_step_per_call", False):
        return ENGINE
    if kernels_on and reaches_kernel(solver_cls):
        return COMPILED
    return PLAIN


def reaches_kernel(solver_cls: type) -> bool:
    """Whether the solver's ``advance`` calls a ``@kernel`` function, directly or through the functions and
    methods it names (``super().advance`` included), ``DEPTH`` calls deep at most."""
    seen: set[int] = set()
    for owner, fn in _defined(solver_cls, "advance"):
        if _reaches(fn, solver_cls, owner, seen, DEPTH):
            return True
        if "super" not in _names(fn.__code__):
            return False  # this advance does not hand over to the next one: the classes above never step
    return False


def _defined(cls: type, name: str) -> Iterator[tuple[type, types.FunctionType]]:
    """Each class of ``cls``'s MRO that defines function ``name`` itself, nearest first, with the function."""
    for owner in cls.__mro__:
        fn = owner.__dict__.get(name)
        if isinstance(fn, (staticmethod, classmethod)):
            fn = fn.__func__
        if isinstance(fn, types.FunctionType):
            yield owner, fn


def _names(code: types.CodeType) -> set[str]:
    """The global and attribute names a function's code uses, its nested functions' and comprehensions' too."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names(const)
    return names


def _reaches(fn: Any, cls: type, owner: type, seen: set[int], depth: int) -> bool:
    """Whether ``fn`` (defined on ``owner``, a class of ``cls``'s MRO, or a module function) names a kernel, or
    calls something that does."""
    if isinstance(fn, Kernel):
        return True
    if not isinstance(fn, types.FunctionType) or id(fn) in seen or depth <= 0:
        return False
    seen.add(id(fn))
    names = _names(fn.__code__)
    for name in names:
        target = fn.__globals__.get(name)
        if isinstance(target, Kernel):
            return True
        if isinstance(target, types.FunctionType) and _reaches(target, cls, owner, seen, depth - 1):
            return True
        found = _method(cls, name)
        if found is not None and _reaches(found[1], cls, found[0], seen, depth - 1):
            return True
    if "super" in names:  # super().<same name>(...): the next definition up the MRO
        later = cls.__mro__[cls.__mro__.index(owner) + 1:] if owner in cls.__mro__ else ()
        for parent in later:
            up = parent.__dict__.get(fn.__name__)
            if isinstance(up, types.FunctionType):
                return _reaches(up, cls, parent, seen, depth - 1)
    return False


def _method(cls: type, name: str) -> tuple[type, types.FunctionType] | None:
    """The class that ``cls.<name>`` is found on and the plain function behind it, when it is a method."""
    for owner in cls.__mro__:
        if name in owner.__dict__:
            value = owner.__dict__[name]
            if isinstance(value, (staticmethod, classmethod)):
                value = value.__func__
            return (owner, value) if isinstance(value, types.FunctionType) else None
    return None
