"""``stackx verify DIR CONFIG...``: run configs again and compare every byte with ``DIR/manifest.json``.

An output folder may come from anyone, and its manifest is data anyone can edit, so the manifest never
decides what code runs. What runs is named by the user:
- ``stackx verify DIR CONFIG...``: the named config files (or folders of them), and the local plugins that
  ``stackx run CONFIG...`` would import with them (``--plugins P``, else the ``plugins/`` folder in each
  config's own folder, never one above); each config re-makes the experiment of its name, with the ``--set``
  overrides the manifest records for it (values, never code). Experiments whose config is not named are not
  run again; their files on disk are still checked against the manifest's SHA-256.
- ``stackx verify DIR --trust``: the configs and the plugin folder the manifest records, only when they lie
  inside ``DIR`` (a relative path, no ``..``, no link leading out); an absolute or escaping path is refused,
  exit 2, before anything is imported. Everything it will run and import is listed first.
Either way nothing in ``DIR`` is written: outputs are made in memory. Each artifact is compared three ways:
the re-run against the manifest's SHA-256, the file on disk against the manifest, and, where they differ,
the re-run against the file on disk, to give the first byte that differs. The manifest entry the re-run would
write (resolved config, plugins used) is compared too. Files listed as volatile (``timing.json``) are left out.
A file's size is compared with the manifest's before a byte of it is read, files are hashed and compared
``manifest.CHUNK`` at a time, and a manifest over ``manifest.RECORD_BYTES`` is refused unread, so no file in
the folder, however large (a sparse file costs its maker nothing), takes its size in memory.
Every file in ``DIR`` that the manifest does not know (``strays``) is a difference too: a stray frame is shown
by a player page as if it belonged to the run.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import stat
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from stackx.output import manifest
from stackx.errors import ConfigError, StackxError, readable
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


@dataclass(frozen=True)
class OnDisk:
    """An artifact's file on disk against its manifest entry: whether there is one (a regular file), its size,
    and whether its bytes are the listed ones."""

    present: bool
    size: int = 0
    matches: bool = False


def _open_file(path: Path) -> BinaryIO | None:
    """``path`` open for reading when it is a regular file, else None (missing, a folder, a FIFO, a device).
    Opened without waiting, so a FIFO put in a file's place cannot hold verify up."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError):
        return None
    fh = os.fdopen(fd, "rb")
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        fh.close()
        return None
    return fh


@contextmanager
def _reader(source: bytes | Path) -> Iterator[tuple[Callable[[int], bytes], int]]:
    """A ``read(n)`` over bytes in memory or a file on disk, and its size (a file that is gone reads empty)."""
    if isinstance(source, bytes):
        stream, size = io.BytesIO(source), len(source)
    else:
        fh = _open_file(source)
        stream, size = (fh, os.fstat(fh.fileno()).st_size) if fh is not None else (io.BytesIO(), 0)
    with stream:
        yield stream.read, size


def first_difference(a: bytes | Path, b: bytes | Path) -> str:
    """Where two byte strings (a file's bytes, or bytes in memory) first differ, in words. Files are read
    ``manifest.CHUNK`` at a time and only up to the first difference, so a huge file beside a small re-run
    costs no more than the re-run's size in reading."""
    offset = 0
    with _reader(a) as (read_a, size_a), _reader(b) as (read_b, size_b):
        while True:
            x, y = read_a(manifest.CHUNK), read_b(manifest.CHUNK)
            if x != y or not x:
                offset += next((i for i, (p, q) in enumerate(zip(x, y)) if p != q), min(len(x), len(y)))
                return f"first different byte at offset {offset} ({size_a} bytes against {size_b})"
            offset += len(x)


def _listed_size(listed: dict[str, Any]) -> int | None:
    """The size the manifest lists for an artifact, when it lists one that is a size."""
    size = listed.get("bytes")
    return size if isinstance(size, int) and not isinstance(size, bool) and size >= 0 else None


def _look(disk: Path, listed: dict[str, Any]) -> OnDisk:
    """The file on disk against its manifest entry. The sizes are compared first, so a file of another size is
    a difference without a byte read; one of the listed size is hashed in chunks."""
    fh = _open_file(disk)
    if fh is None:
        return OnDisk(False)
    with fh:
        size, listed_size = os.fstat(fh.fileno()).st_size, _listed_size(listed)
        if listed_size is not None and size != listed_size:
            return OnDisk(True, size, False)
        digest = hashlib.sha256()
        for piece in manifest.chunks(fh):
            digest.update(piece)
        return OnDisk(True, size, digest.hexdigest() == listed["sha256"])


def _shown(text: str) -> str:
    """A string from the manifest, safe to print on a terminal (quoted when it holds anything unprintable)."""
    return text if text.isprintable() else json.dumps(text)


def _on_disk(name: str, listed: dict[str, Any], disk: Path, fresh: bytes | None,
             seen: OnDisk | None = None) -> list[str]:
    """What is wrong with the file on disk against the manifest (against the re-run too, when there is one);
    ``seen``: the file already looked at."""
    seen = seen or _look(disk, listed)
    if not seen.present:
        return [f"{name}: missing from {disk.parent}"]
    if seen.matches:
        return []
    size = _listed_size(listed)
    sizes = f"; {seen.size} bytes, the manifest lists {size}" if size is not None and size != seen.size else ""
    against = f"; against the re-run: {first_difference(disk, fresh)}" if fresh is not None else ""
    return [f"{name}: the file on disk differs from the manifest (changed after the run){sizes}{against}"]


def _artifact(name: str, listed: dict[str, Any], fresh: bytes | None, disk: Path) -> list[str]:
    """What is wrong with one artifact, as lines (none when every copy agrees)."""
    problems = []
    seen = _look(disk, listed)
    if fresh is None:
        problems.append(f"{name}: listed in the manifest, but the re-run does not write it")
    elif manifest.sha256(fresh) != listed["sha256"]:
        against = f"; against the file on disk: {first_difference(fresh, disk)}" if seen.matches else ""
        problems.append(f"{name}: the re-run differs from the manifest{against}")
    return problems + _on_disk(name, listed, disk, fresh, seen)


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
    stem, as ``stackx run`` names it), with the plugins ``stackx run`` would import for it; a config's own
    ``plugins/`` folder inside ``folder`` is imported only when ``--plugins`` names it (configs are data,
    plugins code)."""
    from stackx.config.experiment import config_files, own_plugins

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
        found = own_plugins(config) if plugins is None else None
        if found is not None and not (found.is_dir() or found.is_symlink()):
            found = None
        if found is not None and found.resolve().is_relative_to(folder.resolve()):
            raise ConfigError(f"its plugins/ folder, {found}, lies inside {folder}, the folder being "
                              f"verified: name it with --plugins to import it, or use --trust", file=config)
        replays[name] = Replay(name, Path(config), _sets(folder, name, experiments[name]), plugins or found)
    return [replays[name] for name in sorted(replays)]


def trusted(folder: Path, experiments: dict[str, Any]) -> list[Replay]:
    """Every experiment, re-made from the config and plugin folder the manifest records, all inside ``folder``.

    Refused whole, before anything is imported, when any of them is not: an absolute or escaping path, a link
    leading out, a plugin file that is a link to elsewhere, or a ``plugins/`` folder that loading the config
    would pick up (the one in its own folder) where the manifest records none.
    """
    from stackx.config.experiment import own_plugins

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
            own = own_plugins(str(config))
            if own.is_dir() or own.is_symlink():
                raise _refused(folder, f"{key}.plugins", f"the manifest records no plugin folder, but loading "
                                                         f"the config would import {own} (in its folder)")
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


def _import_plugins(replays: list[Replay], notice: Say | None) -> None:
    """Import the plugin folders the replays name, each checked as every command checks them (a planted or
    foreign file refused before any of it runs), and name the files imported in one line."""
    from stackx import registry
    from stackx.config.experiment import local_plugins

    before = registry.imported_count()
    try:
        for plugins in dict.fromkeys(replay.plugins for replay in replays if replay.plugins is not None):
            local_plugins(plugins, None)
    finally:  # what ran is named even when a later folder is refused
        line = registry.imported_line(before)
        if line is not None and notice is not None:
            notice(line)


def verify_experiment(folder: Path, replay: Replay, listed: dict[str, Any], say: Say) -> int:
    """Re-make one experiment of the manifest; report and count what differs."""
    from stackx.config.experiment import load
    from stackx.run.runner import run_experiment
    from stackx.run.session import stage

    name = replay.name
    if manifest.file_sha256(replay.config) != listed.get("config_sha256"):
        say(f"note {name}: {replay.config} has changed since the run")
    try:
        spec = load(str(replay.config), replay.sets or None, replay.plugins)
        files = stage(spec, run_experiment(spec), folder).staged
    except StackxError as exc:
        say(f"DIFF {name}: the re-run failed: {readable(str(exc))}")
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
           trust: bool = False, notice: Say | None = None) -> int:
    """Verify an output folder against the named ``configs`` (or, with ``trust``, the configs it holds);
    return the number of differences (0: every byte of what was checked identical). The local plugin files
    imported are named in one line to ``notice`` before anything runs."""
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
    _import_plugins(replays, notice)
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
    digest = manifest.file_sha256(folder / manifest.MANIFEST)
    ran = f"{len(chosen)} experiment(s)" + (f" of {len(experiments)} ({skipped} not named)" if skipped else "")
    if differences:
        say(f"verify: {differences} difference(s) in {folder} ({ran} run again, {artifacts} artifact(s))")
    else:
        say(f"verify: {ran}, {artifacts} artifact(s): every byte identical to {folder / manifest.MANIFEST} "
            f"(sha256 {digest})")
    return differences
