"""``stackx verify DIR CONFIG...``: run configs again and compare every byte with ``DIR/manifest.json``.

An output folder may come from anyone, and its manifest is data anyone can edit, so the manifest never
decides what code runs. What runs is named by the user:
- ``stackx verify DIR CONFIG...``: the named config files (or folders of them), and the local plugins that
  ``stackx run CONFIG...`` would import with them (``--plugins P``, else the ``plugins/`` folder nearest to
  each config); each config re-makes the experiment of its name, with the ``--set`` overrides the manifest
  records for it (values, never code). Experiments whose config is not named are not run again; their files
  on disk are still checked against the manifest's SHA-256.
- ``stackx verify DIR --trust``: the configs and the plugin folder the manifest records, only when they lie
  inside ``DIR`` (a relative path, no ``..``, no link leading out); an absolute or escaping path is refused,
  exit 2, before anything is imported. Everything it will run and import is listed first.
Either way nothing in ``DIR`` is written: outputs are made in memory. Each artifact is compared three ways:
the re-run against the manifest's SHA-256, the file on disk against the manifest, and, where they differ,
the re-run against the file on disk, to give the first byte that differs. The manifest entry the re-run would
write (resolved config, plugins used) is compared too. Files listed as volatile (``timing.json``) are left out.
Every file in ``DIR`` that the manifest does not know (``strays``) is a difference too: a stray frame is shown
by a player page as if it belonged to the run.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stackx.output import manifest
from stackx.errors import ConfigError, StackxError
from stackx.output.outdir import FAILED_SUFFIX

Say = Callable[[str], None]


@dataclass(frozen=True)
class Replay:
    """One experiment of the manifest to make again: the config file to load, the ``--set`` overrides the
    manifest records for it, and the local plugin folder whose ``*.py`` files are imported (None: none)."""

    name: str
    config: Path
    sets: list[str]
    plugins: Path | None


def first_difference(a: bytes, b: bytes) -> str:
    """Where two byte strings first differ, in words."""
    n = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    return f"first different byte at offset {n} ({len(a)} bytes against {len(b)})"


def _shown(text: str) -> str:
    """A string from the manifest, safe to print on a terminal (quoted when it holds anything unprintable)."""
    return text if text.isprintable() else json.dumps(text)


def _on_disk(name: str, listed: dict[str, Any], disk: Path, fresh: bytes | None) -> list[str]:
    """What is wrong with the file on disk against the manifest (against the re-run too, when there is one)."""
    on_disk = disk.read_bytes() if disk.is_file() else None
    if on_disk is None:
        return [f"{name}: missing from {disk.parent}"]
    if manifest.sha256(on_disk) == listed["sha256"]:
        return []
    against = f"; against the re-run: {first_difference(on_disk, fresh)}" if fresh is not None else ""
    return [f"{name}: the file on disk differs from the manifest (changed after the run){against}"]


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
    return problems + _on_disk(name, listed, disk, fresh)


def _plugin_files(folder: Path) -> list[Path]:
    """The files of a local plugin folder that are imported (as ``registry.load_local_plugins`` picks them)."""
    return sorted(p for p in folder.glob("*.py") if not p.name.startswith("_"))


def _refused(folder: Path, where: str, why: str) -> ConfigError:
    return ConfigError(f"{why}; --trust runs only configs and plugins inside {folder}: name the configs instead "
                       f"(stackx verify {folder} CONFIG...)", file=str(folder / manifest.MANIFEST), key=where)


def _sets(folder: Path, name: str, listed: dict[str, Any]) -> list[str]:
    sets = listed.get("sets") or []
    if not (isinstance(sets, list) and all(isinstance(s, str) for s in sets)):
        raise ConfigError("not a list of key.path=value overrides", file=str(folder / manifest.MANIFEST),
                          key=f"experiments.{_shown(name)}.sets")
    return sets


def named(folder: Path, experiments: dict[str, Any], paths: list[str], plugins: Path | None) -> list[Replay]:
    """The experiments re-made from configs named on the command line, each matched by its name (the file
    stem, as ``stackx run`` names it), with the plugins ``stackx run`` would import for it; a ``plugins/``
    folder inside ``folder`` is imported only when ``--plugins`` names it (configs are data, plugins code)."""
    from stackx.config.experiment import config_files, nearest_plugins

    if plugins is not None and not plugins.is_dir():
        raise ConfigError("--plugins: no such folder", file=str(plugins))
    replays: dict[str, Replay] = {}
    for config in config_files(paths):
        name = Path(config).stem
        if name not in experiments:
            listed = ", ".join(_shown(n) for n in sorted(experiments)) or "none"
            raise ConfigError(f"makes experiment {name!r}, which {folder / manifest.MANIFEST} does not list "
                              f"(it lists: {listed})", file=config)
        if name in replays:
            raise ConfigError(f"also makes experiment {name!r}, named by {replays[name].config}; name one",
                              file=config)
        found = nearest_plugins(config) if plugins is None else None
        if found is not None and found.resolve().is_relative_to(folder.resolve()):
            raise ConfigError(f"its nearest plugins/ folder, {found}, lies inside {folder}, the folder being "
                              f"verified: name it with --plugins to import it, or use --trust", file=config)
        replays[name] = Replay(name, Path(config), _sets(folder, name, experiments[name]), plugins or found)
    return [replays[name] for name in sorted(replays)]


def trusted(folder: Path, experiments: dict[str, Any]) -> list[Replay]:
    """Every experiment, re-made from the config and plugin folder the manifest records, all inside ``folder``.

    Refused whole, before anything is imported, when any of them is not: an absolute or escaping path, a link
    leading out, a plugin file that is a link to elsewhere, or a ``plugins/`` folder that loading the config
    would pick up (the nearest at or above it) where the manifest records none.
    """
    from stackx.config.experiment import nearest_plugins

    replays = []
    for name, listed in sorted(experiments.items()):
        key = f"experiments.{_shown(name)}"
        try:
            config = manifest.inside(listed.get("config"), folder)
        except ValueError as exc:
            raise _refused(folder, f"{key}.config", f"config {exc}") from None
        if not config.is_file():
            raise _refused(folder, f"{key}.config", f"config {_shown(str(listed['config']))} is not a file")
        plugins = None
        if listed.get("plugins") is not None:
            try:
                plugins = manifest.inside(listed["plugins"], folder)
            except ValueError as exc:
                raise _refused(folder, f"{key}.plugins", f"plugin folder {exc}") from None
            if not plugins.is_dir():
                raise _refused(folder, f"{key}.plugins", f"plugin folder {_shown(listed['plugins'])} is not a folder")
            for file in _plugin_files(plugins):
                if not file.resolve().is_relative_to(folder.resolve()):
                    raise _refused(folder, f"{key}.plugins", f"plugin file {file} is a link to {file.resolve()}")
        else:
            nearest = nearest_plugins(str(config))
            if nearest is not None:
                raise _refused(folder, f"{key}.plugins", f"the manifest records no plugin folder, but loading "
                                                         f"the config would import {nearest} (nearest to it)")
        replays.append(Replay(name, config, _sets(folder, name, listed), plugins))
    return replays


def _describe(replay: Replay) -> str:
    """What re-making one experiment runs and imports, in one line."""
    sets = "".join(f" --set {_shown(s)}" for s in replay.sets)
    if replay.plugins is None:
        imports = "no local plugins"
    else:
        files = ", ".join(p.name for p in _plugin_files(replay.plugins)) or "no *.py files"
        imports = f"local plugins {replay.plugins}: {files}"
    return f"run  {replay.name}: {replay.config}{sets} ({imports})"


def verify_experiment(folder: Path, replay: Replay, listed: dict[str, Any], say: Say) -> int:
    """Re-make one experiment of the manifest; report and count what differs."""
    from stackx.config.experiment import load
    from stackx.run.runner import run_experiment
    from stackx.run.session import stage

    name = replay.name
    if manifest.sha256(replay.config.read_bytes()) != listed.get("config_sha256"):
        say(f"note {name}: {replay.config} has changed since the run")
    try:
        spec = load(str(replay.config), replay.sets or None, replay.plugins)
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
    for line in problems:
        say(f"DIFF {name}: {line}")
    if not problems:
        say(f"ok   {name}: {len(listed['artifacts'])} artifact(s) identical")
    return len(problems)


def _not_run(folder: Path, name: str, listed: dict[str, Any], say: Say) -> int:
    """An experiment whose config was not named: its files on disk against the manifest only."""
    problems = [p for artifact, entry in sorted(listed["artifacts"].items())
                for p in _on_disk(artifact, entry, folder / artifact, None)]
    for line in problems:
        say(f"DIFF {_shown(name)}: {line}")
    recorded = json.dumps(listed.get("config"))
    say(f"skip {_shown(name)}: not run again, its config was not named (the manifest records {recorded}); "
        f"{len(listed['artifacts']) - len(problems)} of {len(listed['artifacts'])} file(s) on disk as listed")
    return len(problems)


def _checked(folder: Path, doc: dict[str, Any]) -> dict[str, Any]:
    """The manifest's experiments, each with the fields verify reads in the shapes it reads them."""
    for name, listed in doc["experiments"].items():
        artifacts = listed.get("artifacts") if isinstance(listed, dict) else None
        if not (isinstance(artifacts, dict) and all(isinstance(a, str) and isinstance(e, dict)
                                                    and isinstance(e.get("sha256"), str)
                                                    for a, e in artifacts.items())):
            raise ConfigError("not a stackx manifest entry (artifacts: file name -> {sha256, bytes})",
                              file=str(folder / manifest.MANIFEST), key=f"experiments.{_shown(name)}")
        for artifact in artifacts:
            try:
                manifest.inside(artifact, folder)
            except ValueError as exc:
                raise ConfigError(f"artifact {exc}", file=str(folder / manifest.MANIFEST),
                                  key=f"experiments.{_shown(name)}.artifacts") from None
    return doc["experiments"]


def strays(folder: Path, experiments: dict[str, Any]) -> list[str]:
    """Files (and links) under ``folder`` that its manifest does not know, in name order: not an artifact, not
    the folder's own records, not a config or a file of a plugin folder the manifest records inside it. A
    stray file may be an artifact of an older run, or a frame a player page would still show."""
    known = {manifest.MANIFEST, manifest.TIMING}
    inputs: list[str] = []  # plugin folders recorded inside the folder: whatever they hold is theirs
    for listed in experiments.values():
        known |= set(listed["artifacts"])
        for key in ("config", "plugins"):
            try:
                path = manifest.inside(listed.get(key), folder)
            except ValueError:
                continue
            rel = path.relative_to(folder).as_posix()
            (inputs.append(rel + "/") if key == "plugins" else known.add(rel))
    found = []
    for top, dirs, files in os.walk(folder):
        here = Path(top).relative_to(folder)
        links = [d for d in dirs if (Path(top) / d).is_symlink()]
        for name in files + links:
            rel = (here / name).as_posix()
            if rel in known or any(rel.startswith(p) for p in inputs):
                continue
            if here == Path(".") and name.endswith(FAILED_SUFFIX):
                continue  # a failed run's partial measures: the folder's own record
            found.append(rel)
    return sorted(found)


def verify(folder: Path, say: Say, configs: list[str] | None = None, plugins: Path | None = None,
           trust: bool = False) -> int:
    """Verify an output folder against the named ``configs`` (or, with ``trust``, the configs it holds);
    return the number of differences (0: every byte of what was checked identical)."""
    doc = manifest.read(folder)
    if doc is None:
        raise ConfigError(f"no {manifest.MANIFEST} here; run 'stackx run ... --out {folder}' first", file=str(folder))
    experiments = _checked(folder, doc)
    if trust and (configs or plugins is not None):
        raise ConfigError("--trust runs what the manifest records inside the folder; name configs (and "
                          "--plugins) or pass --trust, not both", file=str(folder))
    if trust:
        replays = trusted(folder, experiments)
        say(f"trust: running what {folder / manifest.MANIFEST} records inside {folder}:")
    elif configs:
        replays = named(folder, experiments, configs, plugins)
    else:
        raise ConfigError(f"name the configs to run again (e.g. 'stackx verify {folder} configs/'), or pass "
                          f"--trust to run the configs and plugins the manifest records inside {folder}",
                          file=str(folder))
    for line in map(_describe, replays):
        say(line)
    for dep, now in manifest.versions().items():
        then = doc.get("versions", {}).get(dep)
        if then != now:
            say(f"note {dep}: made with {then}, now {now}")
    chosen = {replay.name: replay for replay in replays}
    differences = sum(verify_experiment(folder, chosen[name], listed, say) if name in chosen
                      else _not_run(folder, name, listed, say) for name, listed in sorted(experiments.items()))
    unknown = strays(folder, experiments)
    for name in unknown:
        say(f"DIFF stray: {_shown(name)}: in {folder} but not in its manifest (left by another run, or put there)")
    differences += len(unknown)
    artifacts = sum(len(experiments[name]["artifacts"]) for name in chosen)
    skipped = len(experiments) - len(chosen)
    digest = manifest.sha256((folder / manifest.MANIFEST).read_bytes())
    ran = f"{len(chosen)} experiment(s)" + (f" of {len(experiments)} ({skipped} not named)" if skipped else "")
    if differences:
        say(f"verify: {differences} difference(s) in {folder} ({ran} run again, {artifacts} artifact(s))")
    else:
        say(f"verify: {ran}, {artifacts} artifact(s): every byte identical to {folder / manifest.MANIFEST} "
            f"(sha256 {digest})")
    return differences
