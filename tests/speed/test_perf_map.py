"""``benchmarks.perf_map`` names numba's machine code for ``perf``: symbols read back as module paths, and the map
it writes covers a function this process compiled."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from benchmarks.perf_map import readable, write_map


def test_a_numba_symbol_reads_as_its_module_path() -> None:
    symbol = ("_ZN6stackx7solvers6planar6banded6factorB3v48B44c8tJTIeFIjxB2IKSgI4CrvQCk0Z4yRYcWsBAK4JIagIAE"
              "5ArrayIdLi2E1C7mutable7alignedE")
    assert readable(symbol) == "stackx.solvers.planar.banded.factor"
    assert readable("__sincos_fma") == "__sincos_fma"  # not numba's: as it is


def test_the_map_names_a_function_compiled_here() -> None:
    numba = pytest.importorskip("numba")

    @numba.njit(cache=False)
    def doubled_sum(x: np.ndarray) -> float:
        return 2.0 * x.sum()

    class Gone:
        pass

    dead = weakref.proxy(Gone())  # a proxy whose object is gone, among the objects the map looks through
    assert any(o is dead for o in gc.get_objects())
    assert doubled_sum(np.arange(4.0)) == 12.0
    path, count = write_map()
    try:
        lines = path.read_text().splitlines()
        assert count == len(lines) > 0
        named = [line.split(" ", 2) for line in lines if line.endswith("doubled_sum")]
        assert named, "the function compiled here is not in the map"
        start, size = int(named[0][0], 16), int(named[0][1], 16)
        assert start > 0 and 0 < size <= 1 << 20
    finally:
        path.unlink(missing_ok=True)
