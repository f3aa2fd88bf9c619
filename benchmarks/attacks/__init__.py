"""The attack trials of ``python -m benchmarks.robust_folder``: one per way an output folder, a config, a
received folder, ``serve`` or a signal has been seen to break stackx's contract, each redone as first seen.

Each trial runs in a fresh folder, bounded in time and memory, and prints one line: its name, PASS, FAIL or
SKIP (with the reason: a trial that needs root to mount a tmpfs, or strace) and what it measured (files lost,
milliseconds, megabytes). ``quick`` trials take a few seconds each and are the ones the test suite runs
(``tests/robust/test_trials.py``).
"""

from __future__ import annotations

from benchmarks.attacks import configs, folder, received, serve, signals
from benchmarks.attacks.kit import Trial

TRIALS: list[Trial] = [
    Trial("mount-inside", folder.mount_inside, needs_root=True, quick=True),
    Trial("concurrent-writer", folder.concurrent_writer),
    Trial("lock-link", folder.lock_link, quick=True),
    Trial("staging-links", folder.staging_links, quick=True),
    Trial("modes", folder.modes, quick=True),
    Trial("out-mount-point", folder.out_mount_point, needs_root=True, quick=True),
    Trial("unwritable-parent", folder.unwritable_parent, needs_root=True),
    *(Trial(name, fn, quick=name == "sparse-manifest") for name, fn in received.SPARSE.items()),
    Trial("compare-explosion", configs.compare_explosion),
    Trial("far-shapes", configs.far_shapes, quick=True),
    Trial("named-runs", configs.named_runs),
    Trial("ancestor-plugins", configs.ancestor_plugins, quick=True),
    Trial("keyvalue-code", configs.keyvalue_code, quick=True),
    Trial("long-lines", configs.long_lines),
    Trial("serve-bad-paths", serve.bad_paths, quick=True),
    Trial("serve-idle", serve.idle_connections),
    Trial("serve-root-swap", serve.root_swap, quick=True),
    Trial("serve-link-race", serve.link_race),
    Trial("sigterm-run", signals.sigterm_run),
    Trial("startup-signals", signals.startup_signals),
    Trial("bench-switch", signals.bench_switch),
    Trial("bench-together", signals.bench_together),
    Trial("init-switch", signals.init_switch),
]
"""Every trial, in the order they run (cheapest kinds first within each group)."""

BY_NAME = {trial.name: trial for trial in TRIALS}
