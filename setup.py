"""Build step that puts the repository's configs and example plugin into the wheel.

Everything about the package is declared in pyproject.toml; this file only extends ``build_py`` so that the
files listed by ``stackx.config.starter.shipped_files`` (``configs/``, ``plugins/``) are copied from the repository's
top level to ``stackx/_starter/`` in the build tree. The repository keeps one copy of each config, and an
installed stackx can write them out with ``stackx init``. An editable install reads them from the checkout
itself, so nothing is copied there.
"""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


def _starter():  # type: ignore[no-untyped-def]
    """``stackx/config/starter.py`` loaded by its path: the build has no stackx (nor its dependencies) to import."""
    spec = importlib.util.spec_from_file_location("stackx_starter", ROOT / "stackx" / "config" / "starter.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildWithConfigs(build_py):
    """``build_py`` that also copies the shipped configs and plugin into ``stackx/_starter/``."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        starter = _starter()
        packaged = Path(self.build_lib, "stackx", starter.PACKAGED)
        shutil.rmtree(packaged, ignore_errors=True)  # no file left over from an earlier build of the same tree
        for name in starter.shipped_files(ROOT):
            target = packaged / name
            self.mkpath(str(target.parent))
            self.copy_file(str(ROOT / name), str(target), preserve_mode=False)


setup(cmdclass={"build_py": BuildWithConfigs})
