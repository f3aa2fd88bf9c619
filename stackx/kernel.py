"""Compiled stepping: solver stages are plain Python loops, compiled by numba when it is enabled.

Every function a stepping loop calls is decorated with ``@kernel``. With numba installed and
``STACKX_JIT`` not set to ``0`` it becomes a compiled function cached on disk; otherwise it stays the
readable Python it was written as. Both paths run the same source, so they give the same numbers.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable[..., object])


def enabled() -> bool:
    """Whether kernels are compiled in this process (decided once, at first use)."""
    if os.environ.get("STACKX_JIT", "1") == "0":
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def kernel(fn: F) -> F:
    """Compile ``fn`` with numba (no fastmath, so IEEE results match the Python path) when enabled."""
    if not enabled():
        return fn
    import numba

    return numba.njit(cache=True, fastmath=False)(fn)  # type: ignore[no-any-return]


prange = range
"""Loop over independent batch rows; ``numba.prange`` when kernels are compiled in parallel."""
