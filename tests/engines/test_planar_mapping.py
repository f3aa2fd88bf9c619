"""How the engines build a planar scene: friction mixed as stackx mixes it, sqrt(mu_a mu_b) between boxes and
the box's own against the ground, even when the boxes' coefficients differ; static boxes that never move.

Boxes slide at 3 m/s for 0.25 s: one of mu 0.2 and one of mu 0.8 on the ground, one of mu 0.5 on a static
shelf of mu 0.125. Coulomb's answer, worked out here: each loses mu g t of its speed, with mu the box's own on
the ground and sqrt(0.5 x 0.125) = 0.25 on the shelf."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.run.runner import run_experiment
from tests.engines.need import engine_params

SCENE = """
scene:
  name: planar
  boxes:
    - {x: 0.0, y: 0.5, vx: 3.0, friction: 0.2}
    - {x: 10.0, y: 0.5, vx: 3.0, friction: 0.8}
    - {x: 20.0, y: 0.5, friction: 0.125, static: true, width: 6.0}
    - {x: 18.0, y: 1.5, vx: 3.0, friction: 0.5}
solver: {name: pymunk}
gravity: -9.8
dt: 1/60
steps: 15
"""
MU = [0.2, 0.8, 0.25]  # what each sliding box meets: its own twice, then sqrt(0.5 x 0.125)


def run(tmp_path: Path, engine: str):  # type: ignore[no-untyped-def]
    path = tmp_path / "slide.yaml"
    path.write_text(SCENE)
    return run_experiment(load(str(path), [f"solver={{name: {engine}}}"])).runs[0]


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pybox2d's SWIG types, on import
@pytest.mark.parametrize("engine", [e for e in engine_params() if getattr(e, "values", [e])[0] != "mujoco"])
def test_the_2d_engines_slide_each_box_at_its_mixed_coefficient(tmp_path: Path, engine: str) -> None:
    final = run(tmp_path, engine).final
    expected = [3.0 - mu * 9.8 * 0.25 for mu in MU]
    np.testing.assert_allclose(final.vx[0, [0, 1, 3]], expected, rtol=0, atol=1e-4)
    assert (final.x[0, 2], final.y[0, 2], final.angle[0, 2], final.vx[0, 2]) == (20.0, 0.5, 0.0, 0.0)


def test_mujoco_contacts_carry_the_mixed_coefficient(tmp_path: Path) -> None:
    """MuJoCo's soft contacts slide slower than Coulomb at 60 Hz, so its contacts are read instead: each
    carries the coefficient stackx mixes, none the larger of the two (MuJoCo's own mix)."""
    from tests.engines.need import missing

    if why := missing("mujoco"):
        pytest.skip(why)
    import mujoco

    from stackx.solvers.engines.mujoco_engine import MujocoParams, MujocoPlanar
    from stackx.solvers.engines.planar import Boxes

    path = tmp_path / "slide.yaml"
    path.write_text(SCENE)
    state = load(str(path)).runs[0].scene.build()
    world = MujocoPlanar(mujoco, MujocoParams(), -9.8, 1 / 60, Boxes.of(state, 0))
    world.step()
    data = world.data
    found = {}
    for c in data.contact[:data.ncon]:
        bodies = tuple(sorted(int(world.model.geom_bodyid[g]) for g in (c.geom1, c.geom2)))
        found.setdefault(bodies, set()).add(float(c.friction[0]))
    # body 0 is the world (the plane), bodies 1..4 the boxes in state order
    assert found == {(0, 1): {0.2}, (0, 2): {0.8}, (3, 4): {0.25}}
