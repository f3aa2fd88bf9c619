"""``manifest.json``: every artifact of an output folder with its SHA-256, and how it was made.

One manifest per output folder, ``DIR/manifest.json``. Each experiment that ``stackx run`` writes into the
folder gets one entry, switched in with its artifacts in the same step (``stackx.output.folder``); a later run into the same folder merges: an experiment that runs again replaces its entry
whole, a file now written by another experiment leaves the old one's list, and entries of experiments not
run again stay, since their files are still there untouched.

An entry holds what is needed to make the files again and to check them:
- ``config``: the config file and ``config_sha256``, its bytes when it ran;
- ``sets`` and ``plugins``: the ``--set`` overrides and the local plugin folder it was loaded with;
- ``resolved``: the config as it was run: overrides applied, ``runs``/``sweep`` expanded to one entry per
  run, every default filled in by the plugins' params models (see ``config._resolved``);
- ``plugins_used``: each plugin the experiment used and where it came from, with the SHA-256 of a local file;
- ``artifacts``: file name -> ``{sha256, bytes}``.
At the top: the stackx, Python and dependency versions, and ``volatile``: files left out on purpose
(``timing.json``, wall-clock times). There is no time stamp, and paths of files (the config, the plugin folder,
a local plugin's file) are written as seen from the output folder, so the same configs give the same manifest,
byte for byte, wherever the folders are (two checkouts, or one moved with its output folder inside), and
``stackx verify`` compares with it.

A folder's records (``manifest.json``, ``timing.json``) may come from anyone, so they are read with a bound
(``read_record``): a link, something that is not a regular file, or a file over ``RECORD_BYTES`` is refused
before a byte is read. Files of any size (artifacts, configs, plugin files) are hashed in ``CHUNK`` pieces, so
memory does not grow with the file.
"""

from __future__ import annotations

import errno
import functools
import hashlib
import json
import os
import platform
import stat
from collections.abc import Iterator
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any, BinaryIO

from stackx import __version__
from stackx.errors import ConfigError
from stackx.output.outdir import MANIFEST, TIMING, load_json

FORMAT = 1
DEPENDENCIES = ("numpy", "numba", "pydantic", "PyYAML", "typer", "rich")
VOLATILE = {TIMING: "wall-clock time per step; differs from run to run, so it is neither hashed nor verified"}
RECORD_BYTES = 64 << 20
"""Largest ``manifest.json`` or ``timing.json`` read. The largest experiment the limits allow (10,000 runs at
about 1 KB of resolved config each, 10,000 frames at about 120 bytes of artifact entry each) makes a manifest
entry of about 11 MB and 1 MB of timing, so a real folder stays far below; a bigger file is one someone made, and
reading it whole would take its size in memory (a sparse file costs its maker nothing)."""
CHUNK = 1 << 20
"""Bytes read at a time when hashing or comparing a file: memory per file stays at this, whatever its size; a
smaller chunk means more system calls for no gain."""


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def chunks(fh: BinaryIO) -> Iterator[bytes]:
    """The bytes of an open file from where it stands, ``CHUNK`` at a time."""
    while piece := fh.read(CHUNK):
        yield piece


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, read in chunks (memory does not grow with the file)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for piece in chunks(fh):
            digest.update(piece)
    return digest.hexdigest()


def _size(n: int) -> str:
    """A byte count in words a reader takes in at a glance."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if n >= 1 << shift:
            return f"{n / (1 << shift):.1f} {unit}"
    return f"{n} bytes"


def _too_big(name: str, size: str, limit: int) -> ConfigError:
    return ConfigError(f"{size}, more than the {_size(limit)} a stackx record may take (the largest run allowed "
                       f"writes far less), so it is not read; move it away to start a new one", file=name)


def read_record(path: Path, limit: int = RECORD_BYTES, shown: Path | None = None) -> bytes | None:
    """The bytes of one of a folder's own records (``manifest.json``, ``timing.json``); None when there is none.

    Refused with one line naming the file (``shown``, else ``path``; a ``ConfigError``) when it is a link
    (stackx writes its records as files and never follows a link it did not make), not a regular file (a FIFO
    would block, a device may never end), or over ``limit`` bytes: the size is taken from the open file before
    reading, and the read stops one byte past ``limit``, so a file that grows meanwhile is refused too.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    name = str(shown or path)
    try:
        fd = os.open(path, flags)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        why = "a link; stackx writes its records as files" if exc.errno == errno.ELOOP else \
            f"cannot read it: {exc.strerror or exc}"
        raise ConfigError(f"{why}; move it away to start a new one", file=name) from None
    with os.fdopen(fd, "rb") as fh:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise ConfigError("not a regular file; move it away to start a new one", file=name)
        if info.st_size > limit:
            raise _too_big(name, _size(info.st_size), limit)
        try:
            data = fh.read(limit + 1)
        except OSError as exc:
            raise ConfigError(f"cannot read it: {exc.strerror or exc}; move it away to start a new one",
                              file=name) from None
        if len(data) > limit:  # grew since it was measured
            raise _too_big(name, f"over {_size(limit)}", limit)
    return data


@functools.cache
def versions() -> dict[str, str]:
    """Python and every runtime dependency, as installed."""
    out = {"python": platform.python_version()}
    for name in DEPENDENCIES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def relative(path: str | Path, folder: Path) -> str:
    """``path`` as seen from the output ``folder`` (a path on another drive stays absolute)."""
    try:
        return os.path.relpath(Path(path).resolve(), folder.resolve())
    except ValueError:
        return str(Path(path).resolve())


def inside(recorded: object, folder: Path) -> Path:
    """A path the manifest of ``folder`` records, as a path from here, when it names something inside the folder.

    The manifest is data that anyone can edit, so a path in it is never followed out of the folder: raise
    ``ValueError`` saying why for anything that is not a plain relative path (absolute, a drive, ``..``, a
    control character) or that leads out of the folder through a link.
    """
    if not isinstance(recorded, str) or not recorded:
        raise ValueError(f"{json.dumps(recorded)} is not a path")
    if any(ch < " " or ch == "\x7f" for ch in recorded):
        raise ValueError(f"{json.dumps(recorded)} holds a control character")
    posix = PurePosixPath(recorded.replace("\\", "/"))
    if posix.is_absolute() or PureWindowsPath(recorded).drive or ".." in posix.parts:
        raise ValueError(f"{json.dumps(recorded)} is an absolute path" if ".." not in posix.parts
                         else f"{json.dumps(recorded)} climbs out with '..'")
    path = folder.joinpath(*posix.parts)
    if not path.resolve().is_relative_to(folder.resolve()):
        raise ValueError(f"{json.dumps(recorded)} leads out through a link, to {path.resolve()}")
    return path


def _source(plugin: Any, folder: Path) -> dict[str, str]:
    origin = str(getattr(plugin, "plugin_origin", "unknown"))
    out = {"source": origin}
    if origin.endswith(".py") and Path(origin).is_file():
        out = {"source": relative(origin, folder), "sha256": file_sha256(origin)}
    return out


def plugins_used(spec: Any, folder: Path) -> dict[str, dict[str, str]]:
    """``kind:name`` -> where the plugin came from, for every plugin the experiment used."""
    from stackx.outputs import Renderer

    used: dict[str, Any] = {}
    for run in spec.runs:
        used[f"model:{run.model.plugin_name}"] = run.model
        used[f"scene:{run.scene.plugin_name}"] = run.scene
        used[f"solver:{run.solver_cls.plugin_name}"] = run.solver_cls
    for output in spec.outputs:
        used[f"{'renderer' if isinstance(output, Renderer) else 'sink'}:{output.plugin_name}"] = output
    return {key: _source(plugin, folder) for key, plugin in sorted(used.items())}


def entry(spec: Any, files: dict[str, bytes], folder: Path) -> dict[str, Any]:
    """The manifest entry of one experiment that wrote ``files`` into ``folder``."""
    config = Path(spec.file)
    return {
        "config": relative(config, folder),
        "config_sha256": file_sha256(config) if config.is_file() else None,
        "sets": list(spec.sets),
        "plugins": relative(spec.plugins, folder) if spec.plugins is not None else None,
        "resolved": spec.resolved,
        "plugins_used": plugins_used(spec, folder),
        "artifacts": {name: {"sha256": sha256(data), "bytes": len(data)} for name, data in sorted(files.items())},
    }


def header() -> dict[str, Any]:
    return {"format": FORMAT, "stackx": __version__, "versions": versions(), "volatile": VOLATILE}


def read(folder: Path) -> dict[str, Any] | None:
    """The folder's manifest, None when there is none; a file that is not one (or is larger than any manifest,
    see ``read_record``) is refused, never overwritten."""
    path = folder / MANIFEST
    data = read_record(path)
    if data is None:
        return None
    try:
        doc = load_json(data)
    except ValueError as exc:
        raise ConfigError(f"not a readable stackx manifest ({exc}); move it away to start a new one",
                          file=str(path)) from None
    if not (isinstance(doc, dict) and doc.get("format") == FORMAT and isinstance(doc.get("experiments"), dict)):
        raise ConfigError(f"not a stackx manifest of format {FORMAT}; move it away to start a new one",
                          file=str(path))
    return doc


def merged(doc: dict[str, Any] | None, name: str, new: dict[str, Any]) -> dict[str, Any]:
    """``doc`` with experiment ``name``'s entry replaced by ``new``, and its files taken off other entries."""
    experiments = dict(doc["experiments"]) if doc else {}
    for other, old in experiments.items():
        if other != name:
            kept = {f: h for f, h in old["artifacts"].items() if f not in new["artifacts"]}
            experiments[other] = {**old, "artifacts": kept}
    experiments[name] = new
    return {**header(), "experiments": dict(sorted(experiments.items()))}
