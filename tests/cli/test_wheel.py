"""From a wheel, not a clone: build it, install it into a fresh venv, and from an empty folder run exactly
``stackx init lab && stackx run lab/configs/``; the lab's artifacts are those of the repository's configs.

Selected alone with ``-m wheel``; part of the default run. The build fetches its backend (setuptools) from the
package index as any ``pip wheel`` does. The venv sees the packages of the Python running the tests (a
``.pth`` file naming its site folders, so the same holds whether that Python is a venv or the system's), so
stackx is installed into it with ``--no-deps`` (by this Python's pip, ``--python``) and nothing else is
downloaded.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import stackx
from tests.conftest import REPO, run_cli
from tests.limits import hang_limit

pytestmark = pytest.mark.wheel

BUILD_INPUTS = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "LICENSE", "stackx", "configs", "plugins")
"""What the build reads; copied to a scratch folder so no build/ or *.egg-info lands in the checkout."""


def _shipped() -> dict[str, bytes]:
    paths = [*REPO.glob("configs/**/*.yaml"), *REPO.glob("plugins/*.py")]
    return {p.relative_to(REPO).as_posix(): p.read_bytes() for p in paths}


def _env(venv: Path) -> dict[str, str]:
    """The environment of a user of the venv: its bin first, no PYTHONPATH pointing at a checkout."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(venv)
    return env


def _site_folders() -> list[str]:
    """Where this Python finds its packages: its site folders (a venv's own, and its base's when it was made
    with ``--system-site-packages``) and the user's, as ``site`` set them up for this interpreter."""
    folders = list(site.getsitepackages())
    if site.ENABLE_USER_SITE:
        folders.append(site.getusersitepackages())
    return [f for f in folders if Path(f).is_dir()]


def _venv_seeing_this_python(venv: Path) -> Path:
    """A venv whose own site folder comes first and that then sees this Python's packages.

    ``venv --system-site-packages`` would reach the *base* interpreter's packages: run from inside a venv,
    that is not where this Python's dependencies are. A ``.pth`` line appends a folder to ``sys.path``
    without running the ``.pth`` files in it, so an editable install of this checkout stays out.
    """
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=hang_limit(120))
    python = venv / "bin" / "python"
    own = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                         check=True, capture_output=True, text=True).stdout.strip()
    (Path(own) / "_tests_outer_site.pth").write_text("".join(f"{f}\n" for f in _site_folders()))
    return python


def test_stackx_init_then_run_from_an_installed_wheel(tmp_path: Path) -> None:
    source = tmp_path / "source"
    source.mkdir()
    for name in BUILD_INPUTS:
        src = REPO / name
        if src.is_dir():
            shutil.copytree(src, source / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(src, source / name)
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(dist), str(source)],
                   check=True, capture_output=True, text=True, timeout=hang_limit(300))
    wheel = next(dist.glob("stackx-*.whl"))
    assert wheel.name.startswith(f"stackx-{stackx.__version__}-")

    # the wheel carries every config and the plugin, byte for byte, once
    with zipfile.ZipFile(wheel) as zf:
        packaged = {n.removeprefix("stackx/_starter/"): zf.read(n) for n in zf.namelist()
                    if n.startswith("stackx/_starter/")}
    assert packaged == _shipped()

    venv = tmp_path / "venv"
    python = _venv_seeing_this_python(venv)
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
                    "--quiet", str(wheel)], check=True, capture_output=True, text=True, timeout=hang_limit(300))

    empty = tmp_path / "empty"
    empty.mkdir()
    env = _env(venv)
    done = subprocess.run(["bash", "-c", "stackx init lab && stackx run lab/configs/"], cwd=empty, env=env,
                          capture_output=True, text=True, timeout=hang_limit(300))
    assert done.returncode == 0, done.stderr

    # it was the installed package that ran, with the version written in one place
    where = subprocess.run(["stackx", "--version"], cwd=empty, env=env, capture_output=True, text=True)
    assert where.stdout.strip() == f"stackx {stackx.__version__}"
    probe = subprocess.run([str(python), "-c", "import importlib.metadata as m, stackx; "
                            "print(stackx.__file__); print(m.version('stackx'))"],
                           cwd=empty, env=env, capture_output=True, text=True, check=True)
    module, version = probe.stdout.split()
    assert Path(module).is_relative_to(venv), module
    assert version == stackx.__version__

    # the lab's artifacts, the same bytes as a run of the repository's configs
    expected = tmp_path / "expected"
    assert run_cli("run", REPO / "configs", "--out", expected, "-q").returncode == 0
    skip = {"timing.json", "manifest.json"}  # wall-clock times; config paths as seen from the folder
    got = {p.name: p.read_bytes() for p in (empty / "out").iterdir() if p.name not in skip}
    want = {p.name: p.read_bytes() for p in expected.iterdir() if p.name not in skip}
    assert {"06-stack.txt", "stack.png", "f11.png", "index.html", "00-check.png"} <= set(want)
    assert got == want

    # the shell completion of the installed command
    completion = subprocess.run(["stackx"], cwd=empty, capture_output=True, text=True, env={
        **env, "_STACKX_COMPLETE": "complete_bash", "COMP_WORDS": "stackx in", "COMP_CWORD": "1"})
    assert completion.stdout.split() == ["init"]
