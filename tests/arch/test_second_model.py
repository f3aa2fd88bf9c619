"""A second model, written here as local plugins, runs from YAML through ``stackx run`` without touching any
file of the column: a pendulum (one angle per row) with its scene, a solver, and a renderer that draws it."""

from __future__ import annotations

import json
import math
import struct
import zlib
from pathlib import Path

from tests.conftest import Cli

PLUGIN = '''
"""A simple pendulum: one bob on a massless rod, its angle measured from hanging straight down."""

import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.render.gfxlib import Canvas
from stackx.models import Model
from stackx.outputs import Renderer
from stackx.registry import models, renderers, scenes, solvers
from stackx.scenes import Scene
from stackx.solvers.base import Solver


@dataclass
class Swing:
    angle: np.ndarray
    rate: np.ndarray
    length: np.ndarray
    FIELDS = ("angle", "rate", "length")

    @property
    def batch(self):
        return self.angle.shape[0]

    def copy(self):
        return Swing(*(getattr(self, k).copy() for k in self.FIELDS))

    def row(self, b):
        return Swing(*(getattr(self, k)[b:b + 1] for k in self.FIELDS))

    @staticmethod
    def concat(states):
        return Swing(*(np.concatenate([getattr(s, k) for s in states]) for k in Swing.FIELDS))


@models.register("pendulum")
class Pendulum(Model):
    State = Swing
    SCALARS = {"top_angle": "largest angle of the final state (rad)"}
    VECTORS = {"angle": "final angle (rad)", "rate": "final angular velocity (rad/s)"}

    @classmethod
    def state_measures(cls, state):
        return {"angle": state.angle[0].tolist(), "rate": state.rate[0].tolist(),
                "top_angle": float(np.abs(state.angle[0]).max())}

    @classmethod
    def measure(cls, frames, steps, dt):
        final = frames[steps]
        return [cls.state_measures(final.row(b)) for b in range(final.batch)]

    @classmethod
    def offender(cls, state, max_speed):
        speed = np.abs(state.rate * state.length)
        bad = ~np.isfinite(speed) | (speed > max_speed)
        if not bad.any():
            return None
        row, body = (int(i) for i in np.argwhere(bad)[0])
        return row, body, "speed", f"moves at {speed[row, body]:.4g} m/s"

    @classmethod
    def motion(cls, state, b):
        return {"angle": state.angle[b].tolist(), "rate": state.rate[b].tolist()}


class SwingParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    length: float = Field(1.0, gt=0)
    angle: float = 0.0


@scenes.register("pendulum")
class PendulumScene(Scene):
    Params = SwingParams
    model = "pendulum"

    def build(self):
        p = self.params
        return Swing(np.array([[p.angle]]), np.array([[0.0]]), np.array([[p.length]]))

    def size(self):
        return 1


class EulerParams(BaseModel):
    model_config = ConfigDict(extra="forbid")


@solvers.register("symplectic")
class Symplectic(Solver):
    """Semi-implicit Euler: rate first, then the angle with the new rate."""

    Params = EulerParams
    models = ("pendulum",)

    def advance(self, state, steps):
        for _ in range(steps):
            state.rate += self.dt[:, None] * (self.gravity[:, None] / state.length) * np.sin(state.angle)
            state.angle += self.dt[:, None] * state.rate


class PictureParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    path: str


@renderers.register("swing")
class SwingPicture(Renderer):
    """The final pendulum: pivot at the top centre, rod in grey, bob as a red square."""

    Params = PictureParams
    models = ("pendulum",)

    def write(self, result, out):
        final = result.runs[0].final
        angle, length = float(final.angle[0, 0]), float(final.length[0, 0])
        c = Canvas(101, 101, (255, 255, 255))
        x = 50 + round(40 * math.sin(angle))
        y = 10 + round(40 * math.cos(angle))
        c.line(50, 10, x, y, (128, 128, 128))
        c.fill_rect(x - 3, y - 3, x + 3, y + 3, (200, 0, 0))
        out.write_bytes(self.params.path, c.png_bytes())
'''

CONFIG = """description: a pendulum let go at 0.5 rad
scene: {name: pendulum, length: 2.0, angle: 0.5}
solver: {name: symplectic}
dt: 1/100
steps: 300
outputs:
  - {sink: metrics, path: pendulum.metrics.json}
  - {render: swing, path: swing.png}
"""


def _project(tmp_path: Path, config: str = CONFIG) -> Path:
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "pendulum.py").write_text(PLUGIN)
    path = tmp_path / "pendulum.yaml"
    path.write_text(config)
    return path


def _swing(angle: float, steps: int, dt: float, length: float, g: float) -> tuple[float, float]:
    """The same recurrence in plain floats: rate += dt*(g/L)*sin(angle); angle += dt*rate."""
    rate = 0.0
    for _ in range(steps):
        rate += dt * (g / length) * math.sin(angle)
        angle += dt * rate
    return angle, rate


def _pixel(png: bytes, x: int, y: int) -> tuple[int, int, int]:
    """One pixel of an unfiltered 8-bit RGB PNG."""
    width = struct.unpack(">I", png[16:20])[0]
    pos, data = 8, b""
    while pos < len(png):
        size = struct.unpack(">I", png[pos:pos + 4])[0]
        if png[pos + 4:pos + 8] == b"IDAT":
            data += png[pos + 8:pos + 8 + size]
        pos += 12 + size
    raw = zlib.decompress(data)
    start = y * (1 + 3 * width) + 1 + 3 * x
    return tuple(raw[start:start + 3])  # type: ignore[return-value]


def test_a_second_model_runs_from_yaml_and_writes_metrics_and_a_picture(cli: Cli, tmp_path: Path) -> None:
    config = _project(tmp_path)
    done = cli("run", config, "--out", tmp_path / "out", "-q")
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "out" / "pendulum.metrics.json").read_text())
    run = doc["runs"]["main"]
    angle, rate = _swing(0.5, 300, 1 / 100, 2.0, -9.8)
    assert abs(run["angle"][0] - angle) < 1e-12 and abs(run["rate"][0] - rate) < 1e-12
    assert run["solver"] == "symplectic" and run["boxes"] == 1
    png = (tmp_path / "out" / "swing.png").read_bytes()
    bob = (50 + round(40 * math.sin(angle)), 10 + round(40 * math.cos(angle)))
    assert _pixel(png, *bob) == (200, 0, 0)
    assert _pixel(png, 100 - bob[0], bob[1]) == (255, 255, 255)  # the mirror image of the bob is blank
    listed = cli("plugins", "--plugins", tmp_path / "plugins").stdout
    assert "pendulum" in listed and "model" in listed


def test_a_column_solver_on_the_pendulum_is_refused_at_its_key(cli: Cli, tmp_path: Path) -> None:
    config = _project(tmp_path, CONFIG.replace("{name: symplectic}", "{name: pgs}"))
    done = cli("run", config, "--out", tmp_path / "out")
    assert done.returncode == 2
    lines = config.read_text().splitlines()
    line = next(i for i, text in enumerate(lines) if "pgs" in text)
    col = lines[line].index("pgs") + 1
    assert done.stderr.strip().splitlines() == [
        f"plugins: imported pendulum.py from {tmp_path / 'plugins'}",
        f"error: {config}:{line + 1}:{col}: solver.name: solver 'pgs' steps column scenes, not 'pendulum' (scene "
        "'pendulum'); solvers of 'pendulum': symplectic"]
    assert not (tmp_path / "out").exists()


def test_a_column_renderer_on_the_pendulum_is_refused(cli: Cli, tmp_path: Path) -> None:
    config = _project(tmp_path, CONFIG.replace("{render: swing, path: swing.png}",
                                               "{render: stack, path: stack.png}"))
    done = cli("run", config, "--out", tmp_path / "out")
    assert done.returncode == 2
    assert done.stderr.strip().endswith("outputs[1].render: 'stack' draws column and planar scenes, not 'pendulum' "
                                          "(run 'main')")
    assert not (tmp_path / "out").exists()
