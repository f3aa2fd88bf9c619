"""Attacks by a received output folder: a 6 GB sparse file (no blocks on disk, a few bytes in a tar) in place
of an artifact, ``manifest.json`` or ``timing.json``.

The contract (docs/outputs.md): ``verify`` and ``run`` compare sizes before reading, hash in chunks and refuse
manifest and timing files over a bound, so their memory stays bounded: each either reports the difference or
refuses in one line, and a run that goes ahead leaves a complete folder.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from benchmarks.attacks.kit import (CONFIGS, Finished, Outcome, can_mount, complete_run, manifest_problems,
                                    mount_tmpfs, stackx)

SPARSE_BYTES = 6 << 30
BOUND_MB = 256
"""Peak resident memory allowed to ``verify`` and ``run`` facing the sparse file (either takes about 60 MB on a
plain folder; reading the file whole takes 6 GB)."""
TIMEOUT_S = 120.0
VOLUME_MB = 64
"""The tmpfs the folder lives on, when this process may mount one: a command that would write the sparse
file's zeros out fails on a full volume instead of filling the machine's disk."""


def _folder(root: Path) -> Path:
    if can_mount():
        return root / "X"
    mount_tmpfs(root / "volume", VOLUME_MB)
    return root / "volume" / "X"


def _judge(done: Finished, folder: Path, allowed: tuple[int, ...]) -> str:
    """'' when ``done`` stayed bounded and ended as allowed; else what went wrong."""
    if done.stopped:
        return done.stopped
    if done.traceback:
        return "a traceback"
    if done.peak_mb > BOUND_MB:
        return f"{done.peak_mb:.0f} MB, over {BOUND_MB} MB"
    if done.code not in allowed:
        return f"exit {done.code} (allowed: {allowed})"
    if done.code == 2 and not done.one_line_refusal():
        return "exit 2 without one error line"
    if done.code == 0 and allowed == (0, 2) and manifest_problems(folder):
        return f"exit 0 leaving {manifest_problems(folder)[0]}"
    return ""


def _sparse_trial(root: Path, victim: str, verify_exits: tuple[int, ...]) -> Outcome:
    """``victim`` of a complete 06-stack folder grown to 6 GB of zeros: ``verify`` with ``verify_exits``,
    then ``run`` over it (exit 0 with a complete folder, or a refusal)."""
    x = _folder(root)
    complete_run("06-stack", x, root)
    os.truncate(x / victim, SPARSE_BYTES)
    checked = stackx("verify", x, CONFIGS / "06-stack.yaml", cwd=root, timeout=TIMEOUT_S)
    ran = stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root, timeout=TIMEOUT_S)
    wrong = [f"{cmd}: {w}" for cmd, w in (("verify", _judge(checked, x, verify_exits)), ("run", _judge(ran, x, (0, 2))))
             if w]
    figure = (f"verify {checked.brief()} {checked.peak_mb:.0f} MB {checked.seconds:.1f} s, run {ran.brief()} "
              f"{ran.peak_mb:.0f} MB {ran.seconds:.1f} s")
    return Outcome(not wrong, figure + "".join(f"; {w}" for w in wrong))


def sparse_manifest(root: Path) -> Outcome:
    """A 6 GB ``manifest.json``: refused (or reported) by ``verify``; ``run`` bounded."""
    return _sparse_trial(root, "manifest.json", (1, 2))


def sparse_timing(root: Path) -> Outcome:
    """A 6 GB ``timing.json``: never compared, but read by both; bounded either way."""
    return _sparse_trial(root, "timing.json", (0, 1, 2))


def sparse_artifact(root: Path) -> Outcome:
    """A 6 GB artifact: ``verify`` reports it differs (its size tells, before any byte is read)."""
    return _sparse_trial(root, "06-stack.txt", (1,))


SPARSE: dict[str, Callable[[Path], Outcome]] = {"sparse-manifest": sparse_manifest, "sparse-timing": sparse_timing,
                                                "sparse-artifact": sparse_artifact}
