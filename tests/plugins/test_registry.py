"""Plugins from the three places: built in, installed entry points, and local plugin folders."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from stackx.errors import ConfigError
from stackx.registry import Registry
from tests.conftest import CONFIGS, REPO, Cli
from tests.lab import reference as ref


def test_unknown_name_lists_known_and_suggests() -> None:
    reg: Registry[type] = Registry("solver")
    reg.register("warm-start")(type("A", (), {}))
    reg.register("pgs")(type("B", (), {}))
    with pytest.raises(ConfigError) as err:
        reg.get("warmstart")
    assert "did you mean 'warm-start'?" in str(err.value)
    assert "pgs (built-in)" in str(err.value)


def test_duplicate_name_names_both_sources(cli: Cli, tmp_path: Path) -> None:
    plugins = tmp_path / "plugins"
    plugins.mkdir()
    (plugins / "again.py").write_text(textwrap.dedent("""
        from stackx.registry import solvers
        from stackx.solvers.column.pgs import PGS

        @solvers.register("pgs")
        class Again(PGS):
            pass
    """))
    shutil.copy(CONFIGS / "06-stack.yaml", tmp_path / "06-stack.yaml")
    done = cli("validate", "06-stack.yaml", "--plugins", "plugins", cwd=tmp_path)  # short names: a line not cut
    assert done.returncode == 2
    assert "defined twice" in done.stderr and "built-in" in done.stderr and "again.py" in done.stderr


def test_example_plugin_is_found_without_installing(cli: Cli, tmp_path: Path) -> None:
    """configs/examples/sor-stack.yaml names 'sor' from plugins/sor.py; omega 1 is the lab solver exactly."""
    done = cli("run", CONFIGS / "examples" / "sor-stack.yaml", "--plugins", REPO / "plugins", "--out", tmp_path, "-q")
    assert done.returncode == 0, done.stderr
    got = dict(ln.split("=", 1) for ln in (tmp_path / "sor-stack.txt").read_text().splitlines())
    lab = ref.max_depth(ref.stack_run().final)
    assert abs(float(got["lab_max_depth"]) - lab) < 1e-12
    # over-relaxed impulses leave the stack less compressed than the lab's 15 plain passes
    assert float(got["sor_max_depth"]) < lab
    assert (tmp_path / "sor-stack.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_entry_point_plugins_are_listed_without_import(tmp_path: Path) -> None:
    """A distribution's entry point is listed by name; its module is imported only when used."""
    site = tmp_path / "site"
    dist = site / "fancy_solvers-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: fancy-solvers\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[stackx.solvers]\nfancy = fancy_solvers:Fancy\n")
    (site / "fancy_solvers.py").write_text(textwrap.dedent("""
        import os
        open(os.environ["FANCY_MARK"], "w").close()
        from stackx.solvers.column.pgs import PGS

        class Fancy(PGS):
            '''The lab solver under another name.'''
    """))
    mark = tmp_path / "imported"
    env = {**os.environ, "PYTHONPATH": f"{site}{os.pathsep}{REPO}", "FANCY_MARK": str(mark), "COLUMNS": "200"}
    listed = subprocess.run([sys.executable, "-m", "stackx", "plugins"], env=env, capture_output=True, text=True,
                            cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    assert any("fancy" in ln and "entry point fancy-solvers" in ln for ln in listed.stdout.splitlines())
    assert not mark.exists()
    config = tmp_path / "fancy.yaml"
    config.write_text((CONFIGS / "03-sink.yaml").read_text().replace("name: pgs", "name: fancy"))
    done = subprocess.run([sys.executable, "-m", "stackx", "run", str(config), "--out", str(tmp_path / "out"), "-q"],
                          env=env, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert mark.exists()
    depth = float((tmp_path / "out" / "03-sink.txt").read_text().split("=")[1])
    assert abs(depth - ref.max_depth(ref.simulate([1.5], 600, 10, correction=False).final)) < 1e-12
