"""The C transcriptions (``steps.c``), compiled on the spot with the system's C compiler and called via ctypes.

``build()`` compiles into a temporary folder with ``-O2 -ffp-contract=off`` (no fused multiply-add, so
every rounding is the one Python makes) and returns the library, or the reason it could not: no compiler
on ``PATH`` (``$CC``, ``cc``, ``gcc`` or ``clang``) or a failed compile. One ctypes call steps every row
for every step, so the call's own cost (about a microsecond) is paid once per run.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

SOURCE = Path(__file__).with_name("steps.c")
FLAGS = ["-O2", "-ffp-contract=off", "-fPIC", "-shared"]

_D = ctypes.POINTER(ctypes.c_double)
_I64 = ctypes.POINTER(ctypes.c_int64)
_B = ctypes.POINTER(ctypes.c_ubyte)
_LONG = ctypes.c_long


def compiler() -> str | None:
    """The C compiler to use: ``$CC``, else the first of cc, gcc, clang on ``PATH``."""
    if os.environ.get("CC"):
        return shutil.which(os.environ["CC"])
    return next((path for name in ("cc", "gcc", "clang") if (path := shutil.which(name))), None)


def _ptr(a: np.ndarray, kind: type) -> object:
    return a.ctypes.data_as(kind)


class Native:
    """The C steppers; arrays are numpy, shaped like stackx's ``(rows, boxes)``, changed in place."""

    def __init__(self, path: Path, command: list[str]) -> None:
        self.lib = ctypes.CDLL(str(path))
        self.command = command
        self.lib.lab_advance.restype = None
        self.lib.lab_advance.argtypes = [_LONG, _LONG, _D, _D, _D, _D, _D, _D, _I64, _B, _D, _D, _LONG]
        self.lib.warm_start_advance.restype = None
        self.lib.warm_start_advance.argtypes = [_LONG, _LONG, _D, _D, _D, _D, _D, _D, _I64, _B, _B, _D, _D, _D, _D,
                                                _D, _LONG]
        self.lib.exact_advance.restype = None
        self.lib.exact_advance.argtypes = [_LONG, _LONG, _D, _D, _D, _D, _D, _D, _B, _D, _D, _D, _D, _I64, _LONG]

    def lab(self, y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, p: dict[str, np.ndarray],
            steps: int) -> None:
        """``steps`` lab steps of every row (``p``: one value per row of g, dt, iterations, corrects, slop,
        percent)."""
        rows, n = y.shape
        self.lib.lab_advance(rows, n, _ptr(y, _D), _ptr(v, _D), _ptr(inv, _D), _ptr(half, _D), _ptr(p["g"], _D),
                             _ptr(p["dt"], _D), _ptr(p["iterations"], _I64), _ptr(p["corrects"], _B),
                             _ptr(p["slop"], _D), _ptr(p["percent"], _D), steps)

    def warm_start(self, y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, p: dict[str, np.ndarray],
                   impulse: np.ndarray, steps: int) -> None:
        """``steps`` warm-started steps of every row; ``impulse`` ``(rows, boxes)`` carries over."""
        rows, n = y.shape
        work = np.zeros(2 * n)
        self.lib.warm_start_advance(rows, n, _ptr(y, _D), _ptr(v, _D), _ptr(inv, _D), _ptr(half, _D),
                                    _ptr(p["g"], _D), _ptr(p["dt"], _D), _ptr(p["iterations"], _I64),
                                    _ptr(p["carry"], _B), _ptr(p["corrects"], _B), _ptr(p["slop"], _D),
                                    _ptr(p["percent"], _D), _ptr(p["speculative"], _D), _ptr(impulse, _D),
                                    _ptr(work, _D), steps)

    def exact(self, y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, p: dict[str, np.ndarray],
              steps: int) -> None:
        """``steps`` steps of every row with the exact velocity solve."""
        rows, n = y.shape
        work, iwork = np.zeros(10 * n + 7), np.zeros(2 * n + 2, dtype=np.int64)
        self.lib.exact_advance(rows, n, _ptr(y, _D), _ptr(v, _D), _ptr(inv, _D), _ptr(half, _D), _ptr(p["g"], _D),
                               _ptr(p["dt"], _D), _ptr(p["corrects"], _B), _ptr(p["slop"], _D),
                               _ptr(p["percent"], _D), _ptr(p["speculative"], _D), _ptr(work, _D), _ptr(iwork, _I64),
                               steps)


def build(folder: Path) -> Native | str:
    """Compile ``steps.c`` into ``folder``; the library, or why there is none."""
    cc = compiler()
    if cc is None:
        return "no C compiler found ($CC, cc, gcc, clang): C columns skipped"
    out = folder / "steps.so"
    command = [cc, *FLAGS, "-o", str(out), str(SOURCE)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        return f"{' '.join(command)} failed: {(done.stderr or done.stdout).strip().splitlines()[:1]}"
    return Native(out, command)
