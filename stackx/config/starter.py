"""The configs and the example plugin that ship with stackx, and ``stackx init`` that copies them into a folder.

A clone holds them at the repository's top level (``configs/``: the lab, ``configs/hard/``: the hard cases,
``configs/examples/``; ``plugins/``: the example local plugin). A wheel carries the same files as package
data under ``stackx/_starter/``: the build step in ``setup.py`` copies them there from the one copy in the
repository, using ``shipped_files`` below, so what a clone runs and what an installed stackx writes out are
the same bytes. ``stackx init DIR`` writes them into ``DIR``, so that ``stackx run DIR/configs/`` runs the
lab from any folder and ``DIR/configs/examples/`` runs with its plugin named, ``--plugins DIR/plugins``, as in the
repository (a config imports only the ``plugins/`` folder beside it unless told otherwise).

Only the standard library is imported at the top: the build step loads this file by its path, before stackx
or its dependencies are installed.
"""

from __future__ import annotations

import os
from pathlib import Path, PurePosixPath

FOLDERS = ("configs", "plugins")
"""The top-level folders that ship, as they are named in the repository and in a folder made by init."""

PACKAGED = "_starter"
"""Where a wheel keeps them: ``stackx/_starter/configs/...``, ``stackx/_starter/plugins/...``."""

SKIPPED = ("__pycache__",)
"""Folders never shipped: byte-code that Python (or pip, at install time) writes beside a plugin."""


def shipped_files(root: Path) -> list[str]:
    """Every file that ships, as POSIX paths relative to ``root`` (the repository's top level or the packaged
    copy), in name order. Hidden names (editor and temporary files) and byte-code folders are left out."""
    names = []
    for folder in FOLDERS:
        base = root / folder
        if not base.is_dir():
            continue
        for here, dirs, files in os.walk(base):
            dirs[:] = sorted(d for d in dirs if d not in SKIPPED and not d.startswith("."))
            for name in files:
                if not name.startswith("."):
                    names.append((Path(here) / name).relative_to(root).as_posix())
    return sorted(names)


def source_root() -> Path:
    """The tree the shipped files are read from: the packaged copy of an installed wheel, else the checkout
    this module runs from (a clone, or an editable install of one)."""
    from stackx.errors import RunError

    here = Path(__file__).resolve().parents[1]
    packaged = here / PACKAGED
    if packaged.is_dir():
        return packaged
    checkout = here.parent
    if (checkout / "pyproject.toml").is_file() and (checkout / FOLDERS[0]).is_dir():
        return checkout
    raise RunError(f"this installation of stackx ({here}) carries no configs: neither {packaged} nor a "
                   f"checkout's {checkout / FOLDERS[0]} exists; reinstall stackx from its wheel or a clone")


def _taken(target: Path, name: str) -> str | None:
    """What stands where ``name`` would be written under ``target``: a file, a link, or a file in the way
    of its folders; None when the place is free."""
    here = target
    parts = PurePosixPath(name).parts
    for i, part in enumerate(parts):
        here = here / part
        if here.is_symlink():
            return f"{here} is a link"
        if i == len(parts) - 1:
            return f"{here} already exists" if here.exists() else None
        if here.exists() and not here.is_dir():
            return f"{here} is a file, not a folder"
    return None


def init_folder(target: Path) -> list[str]:
    """Write every shipped file into ``target`` (made if missing); return their relative names.

    Nothing is overwritten: when any of the files (or a file in the way of their folders) already exists,
    a ``ConfigError`` names it and how many more there are, and nothing is written. The files are written as
    ``stackx run`` writes its folder (``stackx.output.folder``: the same lock, all of them or none), so an
    interrupted or killed init leaves the folder as it was, never part of the files; where ``target`` holds
    the working folder they are linked into place one by one, and the next stackx command into the folder
    takes back an init killed part-way.
    """
    from stackx.errors import ConfigError
    from stackx.output.folder import FolderUpdate

    update = FolderUpdate(target, here=True)
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise ConfigError("not a folder: stackx init writes configs/ and plugins/ into a folder",
                          file=str(target))
    root = source_root()
    names = shipped_files(root)
    with update:
        taken = [why for why in (_taken(target, name) for name in names) if why is not None]
        if taken:
            more = f" (and {len(taken) - 1} more)" if len(taken) > 1 else ""
            raise ConfigError(f"{taken[0]}{more}; stackx init never overwrites, so nothing was written: "
                              f"choose a new or empty folder", file=str(target))
        update.write({name: (root / name).read_bytes() for name in names})
        update.commit()
    return names


def summary(target: Path, names: list[str]) -> list[str]:
    """What init wrote, one line per folder with its file count, and the command that runs the lab."""
    counts: dict[str, int] = {}
    for name in names:
        folder = str(PurePosixPath(name).parent)
        counts[folder] = counts.get(folder, 0) + 1
    lines = [f"wrote {len(names)} files into {target}:"]
    lines += [f"  {(target / folder).as_posix()}/  {n} file{'s' if n != 1 else ''}" for folder, n in counts.items()]
    lines.append(f"run the lab: stackx run {(target / FOLDERS[0]).as_posix()}/")
    return lines
