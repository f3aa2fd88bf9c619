"""Base of the two output plugin kinds: sinks (numbers to files) and renderers (pictures and pages).

An output is configured once per experiment. Before anything runs, ``check`` validates what it refers to
(run names, measures, box indices) and ``frame_steps`` says which intermediate states it needs recorded;
afterwards ``write`` turns the finished results into files through the staged output folder. Outputs never
step physics. A renderer draws the worlds of the models it names in ``models``; a sink writes measures of any
model.
"""

from __future__ import annotations

import re
import string
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from pydantic import BaseModel

from stackx import registry
from stackx.errors import Fail
from stackx.output.outdir import check_place, safe_relative

if TYPE_CHECKING:
    from stackx.output.outdir import OutputDir
    from stackx.run.results import ExperimentResult
    from stackx.config.spec import Plan


MAX_NAME_BYTES = 255
"""Longest file or folder name (in UTF-8 bytes) that Linux, macOS and Windows file systems all accept."""
MAX_PATH_BYTES = 1024
"""Longest output path, in UTF-8 bytes, relative to the output folder (macOS's limit for a whole path)."""
MAX_DEPTH = 16
"""Most folders and file in one output path (``a/b/c.png`` is 3)."""
NOT_PORTABLE = set('<>:"|?*\\')  # characters Windows refuses in a name (a backslash also separates folders there)
RESERVED = re.compile(r"(CON|PRN|AUX|NUL|COM[0-9]|LPT[0-9])(\..*)?", re.IGNORECASE)  # Windows device names
CODE_SUFFIXES = (".py", ".pyc", ".pyo", ".pyw", ".pyz", ".pth")
"""Endings of files Python imports or runs (``.pth``: at start-up, from site-packages); no output ends so."""
PLUGIN_FOLDER = "plugins"
"""The name of a local plugin folder: no output path starts with it."""
SPEC = re.compile(r"(0?[1-9])?d?")
"""Format specs a file name template may use: none, ``d``, or a width up to 9, zero-padded or not
(``{index:03d}``). A wider or other spec could make one name gigabytes long."""


def path_problem(name: object) -> str | None:
    """Why ``name`` is not a portable relative file path (None when it is): every component a name that Linux,
    macOS and Windows all accept, none empty, ``.`` or ``..``, and a bounded depth and length."""
    if not isinstance(name, str) or not name:
        return "an output path is a non-empty file name, e.g. out.json"
    try:
        size = len(name.encode("utf-8"))
    except UnicodeEncodeError as exc:
        return f"{name!r} holds {name[exc.start]!r}, half of a character (a lone surrogate), which no file can be named"
    shown = name if len(name) <= 60 else name[:57] + "..."
    if size > MAX_PATH_BYTES:
        return f"{shown!r} is {size:,} bytes long; an output path is at most {MAX_PATH_BYTES:,}"
    parts = name.split("/")
    if len(parts) > MAX_DEPTH:
        return f"{shown!r} is {len(parts):,} folders deep; an output path is at most {MAX_DEPTH} deep"
    for part in parts:
        if part in ("", ".", ".."):
            what = "an empty folder name (a leading, doubled or trailing '/')" if not part else repr(part)
            return f"{shown!r} holds {what}; write a plain relative path inside the output folder, e.g. sub/out.json"
        if len(part.encode("utf-8")) > MAX_NAME_BYTES:
            return f"{shown!r}: a name of {len(part.encode('utf-8')):,} bytes; a file or folder name is at most " \
                   f"{MAX_NAME_BYTES}"
        bad = next((c for c in part if c in NOT_PORTABLE or ord(c) < 32 or ord(c) == 127), None)
        if bad is not None:
            return f"{shown!r} holds {bad!r}, which not every system accepts in a file name"
        if part[-1] in " .":
            return f"{shown!r}: a name ending in {part[-1]!r} is not portable (Windows drops it)"
        if RESERVED.fullmatch(part):
            return f"{shown!r}: {part!r} is a device name on Windows; choose another name"
    return None


def template_problem(template: str, fields: set[str]) -> str | None:
    """Why a file name template such as ``f{index:02d}.png`` is refused (None when it is not): a field not in
    ``fields``, a conversion or an attribute, or a format spec outside ``SPEC``."""
    try:
        pieces = list(string.Formatter().parse(template))
    except ValueError as exc:
        return f"bad template {template!r}: {exc}"
    allowed = ", ".join("{" + f + "}" for f in sorted(fields))
    for _, field, spec, conversion in pieces:
        if field is None:
            continue
        if field not in fields:
            return f"bad template {template!r}: unknown field {{{field}}}; allowed: {allowed}"
        if conversion is not None or not SPEC.fullmatch(spec or ""):
            return (f"bad template {template!r}: {{{field}{'!' + conversion if conversion else ''}"
                    f"{':' + spec if spec else ''}}} is not allowed; a field takes a width up to 9, e.g. "
                    f"{{{field}:03d}}")
    return None


def clashes(written: list[tuple[str, int]]) -> tuple[str, int, str, int, str] | None:
    """The first two files that cannot both be written, as (name, its output, the earlier name, its output, why):
    the same file, names that differ only in case (one file on macOS and Windows), or a file where another
    output needs a folder (``a`` beside ``a/b.json``). ``written`` lists (path, output index) in config order."""
    files: dict[str, tuple[str, int]] = {}  # folded name -> (name, output)
    folders: dict[str, tuple[str, int]] = {}  # folded folder -> (a file inside it, output)
    for name, i in written:
        key = name.casefold()
        if key in files:
            other, j = files[key]
            return name, i, other, j, f"{other!r} is also written by" if other == name else \
                f"{name!r} and {other!r} differ only in case, one file on macOS and Windows; the other is in"
        if key in folders:
            inside, j = folders[key]
            return name, i, inside, j, f"{name!r} would be a file, but is the folder of {inside!r} in"
        parts = key.split("/")
        for end in range(1, len(parts)):
            folder = "/".join(parts[:end])
            if folder in files:
                other, j = files[folder]
                return name, i, other, j, f"{name!r} needs a folder {other!r}, which is a file in"
            folders.setdefault(folder, (name, i))
        files[key] = (name, i)
    return None


class Output:
    """Common shape of sinks and renderers."""

    Params: ClassVar[type[BaseModel]]
    plugin_name: ClassVar[str]
    needs_runs: ClassVar[bool] = True
    models: ClassVar[tuple[str, ...] | None] = None  # the models whose states it reads; None: any model

    def __init__(self, params: BaseModel) -> None:
        self.params = params

    def files(self) -> list[str]:
        """Paths, relative to the output folder, that ``write`` creates."""
        return [self.params.path]  # type: ignore[attr-defined]

    def pictures(self) -> int:
        """How many pictures ``write`` draws, counted against ``limits.max_frames`` with every other output's;
        known after ``check``, without listing any file name. An output of one file (a sink, a page, a single
        picture) counts none: the config's text limit already bounds how many such outputs there are."""
        return 0

    def check(self, spec: Plan, fail: Fail) -> None:
        """Refuse, before any stepping, what cannot be produced (``raise fail(key_path, message)``)."""

    def frame_steps(self, spec: Plan) -> set[int]:
        """Steps whose state (before that step) must be recorded for ``write``."""
        return set()

    def write(self, result: ExperimentResult, out: OutputDir) -> None:
        raise NotImplementedError


class Sink(Output):
    """Writes measured numbers."""


class Renderer(Output):
    """Draws states or pages."""


def path_key(output: Output, name: str) -> str:
    """The params key that names file ``name`` (e.g. ``player``), for the error position; else ``path``."""
    return next((key for key, value in output.params if value == name), "path")


def code_problem(name: str) -> str | None:
    """Why an output path could become code that stackx or Python runs (None when it cannot): a name Python
    imports or runs (``.py``, ``.pyc``, ``.pth``, ... in any case), or a place under a top-level ``plugins/``
    folder, where a config's own plugin files are looked for when the output folder holds configs. An output
    is data; refusing these keeps a config from writing the code a later command imports."""
    shown = name if len(name) <= 60 else name[:57] + "..."
    suffix = next((s for s in CODE_SUFFIXES if name.casefold().endswith(s)), None)
    if suffix is not None:
        return f"{shown!r} ends in {suffix!r}, a file Python runs; an output is data: choose another extension"
    if name.split("/")[0].casefold() == PLUGIN_FOLDER:
        return f"{shown!r} is inside {PLUGIN_FOLDER}/, where stackx imports plugin files from; write it elsewhere"
    return None


def plugin_folder_problem(root: Path, name: str, folders: list[Path]) -> str | None:
    """Why ``name`` under the output folder ``root`` (resolved) is refused (None when it is not): it is, or lies
    inside, one of the plugin ``folders`` (resolved)."""
    target = root / name
    for folder in folders:
        if target == folder or folder in target.parents:
            shown = name if len(name) <= 60 else name[:57] + "..."
            return f"{shown!r} would land in {folder}, a plugin folder stackx imports from; write outputs elsewhere"
    return None


def confine(output: Output, fail: Fail, root: Path | None = None) -> None:
    """Refuse every path of ``output`` that leaves the folder or could become code (see ``code_problem``), and,
    given ``root``, one that meets a link there or lands in a plugin folder."""
    base = root.resolve() if root is not None else None
    folders = [f.resolve() for f in registry.plugin_folders()]  # --plugins DIR, and every config's own plugins/
    for name in output.files():
        problem = path_problem(name) or code_problem(name)
        if problem is None and base is not None:
            problem = plugin_folder_problem(base, name, folders)
        if problem:
            raise fail((path_key(output, name),), problem)
        try:
            safe_relative(name)
            if root is not None:
                check_place(root, name)
        except ValueError as exc:
            raise fail((path_key(output, name),), str(exc)) from None

