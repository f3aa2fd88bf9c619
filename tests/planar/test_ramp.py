"""The ramp acceptance, from the metrics of a real ``stackx run``: below atan(mu) the box sticks, above it
slides with the acceleration g (sin a - mu cos a), to 1e-6 m/s^2, with the reference solver."""

from __future__ import annotations

import json
import math
from pathlib import Path

import yaml

from tests.conftest import CONFIGS, Cli

STEPS = 60  # one second: the velocity after n steps from rest is n dt a for a constant force


def _analytic(angle_deg: float, mu: float, g: float) -> float:
    """Acceleration down the slope from the forces on a block: gravity along it against Coulomb friction,
    mu times the normal force, while it can; none while tan(angle) <= mu."""
    a = math.radians(angle_deg)
    return 0.0 if math.tan(a) <= mu else g * (math.sin(a) - mu * math.cos(a))


def test_the_ramp_box_sticks_below_atan_mu_and_slides_at_g_sin_minus_mu_cos_above(cli: Cli, tmp_path: Path) -> None:
    names = ("ramp-stick", "ramp-slide")
    done = cli("run", *(CONFIGS / "planar" / f"{n}.yaml" for n in names), "--out", tmp_path, "-q",
               "--set", "solver.name=planar-exact", "--set", f"steps={STEPS}")
    assert done.returncode == 0, done.stderr
    for name in names:
        config = yaml.safe_load((CONFIGS / "planar" / f"{name}.yaml").read_text())
        ramp, g = config["scene"]["ramp"], abs(config["gravity"])
        run = json.loads((tmp_path / f"{name}.metrics.json").read_text())["runs"]["main"]
        assert run["solver"] == "planar-exact"
        a = math.radians(ramp["angle"])
        vx, vy = run["vx"][1], run["vy"][1]  # body 0 is the static ramp
        down = -(vx * math.cos(a) + vy * math.sin(a))
        across = -vx * math.sin(a) + vy * math.cos(a)
        expected = _analytic(ramp["angle"], ramp["mu"], g)
        assert (expected > 0) == (name == "ramp-slide")
        assert abs(down / (STEPS * run["dt"]) - expected) < 1e-6, (name, down / (STEPS * run["dt"]), expected)
        assert abs(across) < 1e-6 and abs(run["w"][1]) < 1e-6  # it stays on the ramp, flat
        assert abs(run["angle"][1] - a) < 1e-6
