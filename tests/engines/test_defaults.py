"""Each engine solver's parameters default to the engine's own settings, read here from a fresh engine.

(Box2D's compiled-in constants and the push-out speed of Box2D v3, which its binding cannot read back, are
not knobs or are taken from the engine's documentation.)"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stackx import registry
from tests.engines.need import missing


def defaults(name: str) -> Any:
    why = missing(name)
    if why:
        pytest.skip(why)
    return registry.solvers.get(name).Params()


def test_pymunk() -> None:
    p = defaults("pymunk")
    import pymunk

    space = pymunk.Space()
    assert p.iterations == space.iterations
    assert p.collision_persistence == space.collision_persistence
    # pymunk computes its built-in bias in single precision: (1 - 0.1f)^60 is 2e-6 off
    assert p.collision_slop == 0.01  # not pymunk's 0.1, which is made for pixels: the lab's slop in metres
    assert p.collision_bias == pytest.approx(space.collision_bias, rel=1e-5)
    assert p.sleep_time_threshold is None and space.sleep_time_threshold == float("inf")


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pybox2d's SWIG types, on import
def test_box2d() -> None:
    p = defaults("box2d")
    import Box2D

    world = Box2D.b2World()
    assert (p.warm_starting, p.continuous_physics, p.allow_sleep) == (world.warmStarting, world.continuousPhysics,
                                                                      world.allowSleeping)
    assert (p.velocity_iterations, p.position_iterations) == (8, 3)  # the manual's and testbed's


def test_box2d_v3() -> None:
    p = defaults("box2d-v3")
    import pyb2d3

    world_def = pyb2d3.WorldDef()
    world = pyb2d3.World()
    assert p.contact_hertz == world_def.contact_hertz
    assert p.contact_damping_ratio == world_def.contact_damping_ratio
    assert p.maximum_linear_speed == world_def.maximum_linear_speed
    assert (p.enable_sleep, p.enable_continuous) == (world.sleeping_enabled, world.continuous_enabled)
    assert p.substeps == 4 and p.contact_push_velocity == 3.0  # Box2D v3's samples and b2DefaultWorldDef


def test_mujoco() -> None:
    p = defaults("mujoco")
    import mujoco

    model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom type="plane" size="1 1 1"/></worldbody>'
                                           '</mujoco>')
    opt = model.opt
    assert (p.iterations, p.ls_iterations, p.noslip_iterations) == (opt.iterations, opt.ls_iterations,
                                                                    opt.noslip_iterations)
    assert (p.tolerance, p.impratio) == (opt.tolerance, opt.impratio)
    assert opt.solver == getattr(mujoco.mjtSolver, f"mjSOL_{p.solver.upper()}")
    assert opt.integrator == getattr(mujoco.mjtIntegrator, f"mjINT_{p.integrator.upper()}")
    assert opt.cone == getattr(mujoco.mjtCone, f"mjCONE_{p.cone.upper()}")
    assert p.warmstart == (not opt.disableflags & mujoco.mjtDisableBit.mjDSBL_WARMSTART)
    np.testing.assert_array_equal(model.geom_solref[0], p.solref)
    np.testing.assert_array_equal(model.geom_solimp[0], p.solimp)
    assert p.substeps == 1
