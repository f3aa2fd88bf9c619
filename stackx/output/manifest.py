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
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

from stackx import __version__
from stackx.errors import ConfigError
from stackx.output.outdir import MANIFEST, TIMING, load_json

FORMAT = 1
DEPENDENCIES = ("numpy", "numba", "pydantic", "PyYAML", "typer", "rich")
VOLATILE = {TIMING: "wall-clock time per step; differs from run to run, so it is neither hashed nor verified"}


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


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
        out = {"source": relative(origin, folder), "sha256": sha256(Path(origin).read_bytes())}
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
        "config_sha256": sha256(config.read_bytes()) if config.is_file() else None,
        "sets": list(spec.sets),
        "plugins": relative(spec.plugins, folder) if spec.plugins is not None else None,
        "resolved": spec.resolved,
        "plugins_used": plugins_used(spec, folder),
        "artifacts": {name: {"sha256": sha256(data), "bytes": len(data)} for name, data in sorted(files.items())},
    }


def header() -> dict[str, Any]:
    return {"format": FORMAT, "stackx": __version__, "versions": versions(), "volatile": VOLATILE}


def read(folder: Path) -> dict[str, Any] | None:
    """The folder's manifest, None when there is none; a file that is not one is refused, never overwritten."""
    path = folder / MANIFEST
    if not path.exists():
        return None
    try:
        doc = load_json(path.read_bytes())
    except (OSError, ValueError) as exc:
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
