"""``stackx verify DIR``: run the manifest's configs again and compare every byte.

Each experiment in ``DIR/manifest.json`` is loaded again the way it was (same config file, ``--set``
overrides and plugin folder, their paths taken from ``DIR`` as the manifest records them), stepped, and its
outputs are made in memory (nothing in ``DIR`` is written).
Each artifact is compared three ways: the re-run against the manifest's SHA-256, the file on disk against
the manifest, and, where they differ, the re-run against the file on disk, to give the first byte that
differs. The manifest entry the re-run would write (resolved config, plugins, versions) is compared too.
Files listed as volatile (``timing.json``) are left out.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from stackx import manifest
from stackx.errors import ConfigError, StackxError

Say = Callable[[str], None]


def first_difference(a: bytes, b: bytes) -> str:
    """Where two byte strings first differ, in words."""
    n = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    return f"first different byte at offset {n} ({len(a)} bytes against {len(b)})"


def _artifact(name: str, listed: dict[str, Any], fresh: bytes | None, disk: Path) -> list[str]:
    """What is wrong with one artifact, as lines (none when every copy agrees)."""
    problems = []
    on_disk = disk.read_bytes() if disk.is_file() else None
    disk_ok = on_disk is not None and manifest.sha256(on_disk) == listed["sha256"]
    if fresh is None:
        problems.append(f"{name}: listed in the manifest, but the re-run does not write it")
    elif manifest.sha256(fresh) != listed["sha256"]:
        against = (f"; against the file on disk: {first_difference(fresh, on_disk)}" if disk_ok and on_disk
                   is not None else "")
        problems.append(f"{name}: the re-run differs from the manifest{against}")
    if on_disk is None:
        problems.append(f"{name}: missing from {disk.parent}")
    elif not disk_ok:
        against = f"; against the re-run: {first_difference(on_disk, fresh)}" if fresh is not None else ""
        problems.append(f"{name}: the file on disk differs from the manifest (changed after the run){against}")
    return problems


def verify_experiment(folder: Path, name: str, listed: dict[str, Any], say: Say) -> int:
    """Re-run one experiment of the manifest; report and count what differs."""
    from stackx.config import load
    from stackx.runner import run_experiment
    from stackx.session import stage

    config = manifest.located(listed["config"], folder)
    if not config.is_file():
        say(f"DIFF {name}: its config {config} is gone")
        return 1
    notes = []
    if manifest.sha256(config.read_bytes()) != listed.get("config_sha256"):
        notes.append(f"note {name}: {config} has changed since the run")
    plugins = manifest.located(listed["plugins"], folder) if listed.get("plugins") else None
    try:
        spec = load(str(config), listed.get("sets") or None, plugins)
        files = stage(spec, run_experiment(spec), folder).staged
    except StackxError as exc:
        say(f"DIFF {name}: the re-run failed: {exc}")
        return 1
    problems = []
    for artifact, entry in sorted(listed["artifacts"].items()):
        problems += _artifact(artifact, entry, files.get(artifact), folder / artifact)
    problems += [f"{extra}: written by the re-run, not in the manifest" for extra in sorted(files)
                 if extra not in listed["artifacts"] and extra not in manifest.VOLATILE]
    again = manifest.entry(spec, {k: v for k, v in files.items() if k in listed["artifacts"]}, folder)
    for key in ("resolved", "plugins_used"):
        if again[key] != listed.get(key):
            problems.append(f"{key}: the re-run's differs from the manifest's")
    for line in notes:
        say(line)
    for line in problems:
        say(f"DIFF {name}: {line}")
    if not problems:
        say(f"ok   {name}: {len(listed['artifacts'])} artifact(s) identical")
    return len(problems)


def verify(folder: Path, say: Say) -> int:
    """Verify a whole output folder; return the number of differences (0: every byte identical)."""
    doc = manifest.read(folder)
    if doc is None:
        raise ConfigError(f"no {manifest.MANIFEST} here; run 'stackx run ... --out {folder}' first", file=str(folder))
    for dep, now in manifest.versions().items():
        then = doc.get("versions", {}).get(dep)
        if then != now:
            say(f"note {dep}: made with {then}, now {now}")
    experiments = doc["experiments"]
    differences = sum(verify_experiment(folder, name, listed, say) for name, listed in sorted(experiments.items()))
    artifacts = sum(len(e["artifacts"]) for e in experiments.values())
    digest = manifest.sha256((folder / manifest.MANIFEST).read_bytes())
    if differences:
        say(f"verify: {differences} difference(s) in {folder} ({len(experiments)} experiment(s), "
            f"{artifacts} artifact(s))")
    else:
        say(f"verify: {len(experiments)} experiment(s), {artifacts} artifact(s): every byte identical to "
            f"{folder / manifest.MANIFEST} (sha256 {digest})")
    return differences
