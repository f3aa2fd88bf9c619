"""How kernels are compiled, cached and chosen (``stackx.kernel``)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from stackx import kernel
from tests.conftest import CONFIGS, REPO

CALLER = '''
from stackx.kernel import kernel
from shifts import shift

@kernel
def twice_shifted(x: float) -> float:
    return 2.0 * shift(x)
'''


def _callee(amount: float) -> str:
    return f"from stackx.kernel import kernel\n\n@kernel\ndef shift(x: float) -> float:\n    return x + {amount}\n"


def _compiled_result(folder: Path, cache: Path) -> str:
    code = "import sys; sys.path.insert(0, sys.argv[1]); from caller import twice_shifted; print(twice_shifted(1.0))"
    done = subprocess.run([sys.executable, "-c", code, str(folder)], capture_output=True, text=True, check=True,
                          env={**os.environ, "STACKX_JIT": "1", "STACKX_CACHE_DIR": str(cache)}, cwd=REPO)
    return done.stdout.strip()


def test_changing_a_called_kernel_does_not_load_stale_compiled_code(tmp_path: Path) -> None:
    """numba checks only the caller's file; the cache folder is keyed by the callee's source as well."""
    (tmp_path / "caller.py").write_text(CALLER)
    (tmp_path / "shifts.py").write_text(_callee(1.5))
    cache = tmp_path / "cache"
    assert _compiled_result(tmp_path, cache) == "5.0"
    assert any(cache.rglob("caller.twice_shifted-*.nbi"))  # it was cached
    (tmp_path / "shifts.py").write_text(_callee(2.5))  # the caller's file is untouched
    assert _compiled_result(tmp_path, cache) == "7.0"


SCALED = '''
from stackx.kernel import kernel
from scales import FACTOR

@kernel
def scaled(x: float) -> float:
    return FACTOR * x
'''


def test_changing_a_constant_imported_from_another_file_does_not_load_stale_compiled_code(tmp_path: Path) -> None:
    """numba compiles a module constant's value into the code; the cache folder is keyed by the value, so a
    changed constant in a file the kernel only imports from is seen."""
    (tmp_path / "caller.py").write_text(SCALED)
    code = "import sys; sys.path.insert(0, sys.argv[1]); from caller import scaled; print(scaled(1.0))"
    cache = tmp_path / "cache"
    env = {**os.environ, "STACKX_JIT": "1", "STACKX_CACHE_DIR": str(cache)}
    answers = []
    for factor in (3, 5):
        (tmp_path / "scales.py").write_text(f"FACTOR = {factor}\n")  # the kernel's file is untouched
        done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True,
                              check=True, env=env, cwd=REPO)
        answers.append(done.stdout.strip())
    assert answers == ["3.0", "5.0"]
    assert any(cache.rglob("caller.scaled-*.nbi"))  # it was cached


def _imports_numba(config: Path, jit: str | None, out: Path) -> bool:
    code = textwrap.dedent("""
        import sys
        from stackx.cli import app
        try:
            app(["run", sys.argv[1], "--out", sys.argv[2], "-q"])
        except SystemExit:
            pass
        print("numba" in sys.modules)
    """)
    env = {k: v for k, v in os.environ.items() if k != "STACKX_JIT"}
    if jit is not None:
        env["STACKX_JIT"] = jit
    done = subprocess.run([sys.executable, "-c", code, str(config), str(out)],
                          capture_output=True, text=True, check=True, env=env, cwd=REPO)
    return done.stdout.strip().splitlines()[-1] == "True"


def test_a_small_run_does_not_wait_for_numba_by_default(tmp_path: Path) -> None:
    assert not _imports_numba(CONFIGS / "06-stack.yaml", None, tmp_path / "auto")
    assert _imports_numba(CONFIGS / "06-stack.yaml", "1", tmp_path / "jit")


@pytest.mark.parametrize("env, work, want", [
    ({}, kernel.DEFAULT_WORK - 1, False),
    ({}, kernel.DEFAULT_WORK, True),
    ({"STACKX_JIT": "auto"}, 10**9, True),
    ({"STACKX_JIT": "0"}, 10**9, False),
    ({"STACKX_JIT": "1"}, 1, True),
    ({"STACKX_JIT_WORK": "10"}, 10, True),
    ({"STACKX_JIT_WORK": "10"}, 9, False),
])
def test_which_batches_are_compiled(env: dict[str, str], work: int, want: bool,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("STACKX_JIT", raising=False)
    monkeypatch.delenv("STACKX_JIT_WORK", raising=False)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    assert kernel.worth_compiling(work) is (want and kernel.available())


def _halve(x: float) -> float:
    return 0.5 * x


@pytest.mark.skipif(not kernel.available(), reason="numba is not installed")
def test_a_block_picks_the_path_of_the_kernels_called_in_it() -> None:
    halve = kernel.kernel(_halve)
    with kernel.compiled(False):
        assert halve(3.0) == 1.5
    assert halve.build().signatures == []  # nothing was compiled for the plain call
    with kernel.compiled(True):
        assert halve(3.0) == 1.5
    assert len(halve.build().signatures) == 1


@kernel.leaf
def _push(v: np.ndarray, weights: np.ndarray, k: int, amount: float) -> float:
    v[k] += weights[k] * amount
    return v[k]


@kernel.kernel
def _pushes(v: np.ndarray, weights: np.ndarray, rounds: int) -> float:
    total = 0.0
    for r in range(rounds):
        for k in range(v.shape[0]):
            total += _push(v, weights, k, 0.1 * r - total * 1e-3)
    return total


def test_a_leaf_compiles_without_reference_counts_and_computes_as_plain() -> None:
    weights = np.linspace(0.5, 1.5, 7)
    plain_v, compiled_v = np.zeros(7), np.zeros(7)
    with kernel.compiled(False):
        plain = _pushes(plain_v, weights, 5)
    with kernel.compiled(True):
        compiled = _pushes(compiled_v, weights, 5)
    assert compiled == plain and compiled_v.tolist() == plain_v.tolist()
    assert plain_v[0] != 0.0
    assert _push.build().targetoptions["_nrt"] is False
    assert "_nrt" not in _pushes.build().targetoptions
