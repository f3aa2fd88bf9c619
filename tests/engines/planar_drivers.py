"""Each engine driven directly on a planar scene read from a config, written here from the engines' own APIs and
the scene's documented geometry, not from stackx's plugins or scene code: the yardstick the engines' planar
stepping is held to.

A scene (a pyramid, a card house, a ramp) is read from the YAML with its documented defaults (1 m boxes of
density 1, gravity -9.8, dt 1/60) and laid out from the geometry its docs give. Every driver builds the world
its own way with the engine's defaults and the documented mapping: the ground a static box 1000 m wide and
10 m deep whose top is y = 0, restitution 0, friction sqrt(mu_a mu_b) and the ground taking the box's own,
pymunk's slop 0.01 m, a Box2D 2.3 polygon inside its 0.01 m skin, MuJoCo's boxes 1 m deep on planar joints.
The ground's friction is given the way each engine offers most directly (a pymunk pre-solve callback, a Box2D
2.3 contact listener, a ground of the scenes' one coefficient in Box2D v3 and MuJoCo), not as the plugins do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

GROUND = (1000.0, 10.0)  # the ground box's width and depth (m), as stackx.solvers.engines.planar documents them


@dataclass
class Box:
    x: float
    y: float
    angle: float  # radians
    w: float
    h: float
    density: float
    mu: float
    static: bool = False

    @property
    def mass(self) -> float:
        return self.density * self.w * self.h

    @property
    def inertia(self) -> float:
        return self.mass * (self.w ** 2 + self.h ** 2) / 12.0


@dataclass
class Scene:
    boxes: list[Box]
    gravity: float
    dt: float
    steps: int


def pyramid(p: dict[str, Any]) -> list[Box]:
    rows, gap, w, h = p["rows"], p.get("gap", 0.05), p.get("width", 1.0), p.get("height", 1.0)
    out = []
    for r in range(rows):
        n = rows - r
        for j in range(n):
            out.append(Box((j - (n - 1) / 2) * (w + gap), h / 2 + r * h, 0.0, w, h, p.get("density", 1.0),
                           p.get("friction", 0.6)))
    return out


def card_house(c: dict[str, Any]) -> list[Box]:
    """Leaning pairs whose top inner corners meet over the pair's centre line and whose lower inner corners
    stand on the floor; flat cards across the facing top outer corners of neighbouring pairs."""
    a = math.radians(c.get("angle", 20.0))
    L, t, gap = c.get("length", 1.0), c.get("thickness", 0.05), c.get("gap", 0.1)
    pairs, levels, mu, rho = c.get("pairs", 2), c.get("levels", 2), c.get("friction", 0.7), c.get("density", 1.0)
    pitch = 2 * (L * math.sin(a) + t * math.cos(a)) + gap
    out, floor = [], 0.0
    for level in range(levels):
        n = pairs - level
        for k in range(n):
            mid = (k - (n - 1) / 2) * pitch
            # a card's top inner corner on the centre line: its centre is (t/2) cos a + (L/2) sin a out from it
            dx = t / 2 * math.cos(a) + L / 2 * math.sin(a)
            cy = floor + t / 2 * math.sin(a) + L / 2 * math.cos(a)
            out.append(Box(mid - dx, cy, -a, t, L, rho, mu))
            out.append(Box(mid + dx, cy, a, t, L, rho, mu))
        top = floor + L * math.cos(a) + t * math.sin(a)
        for k in range(n - 1):
            out.append(Box((k + 0.5 - (n - 1) / 2) * pitch, top + t / 2, 0.0, pitch - t * math.cos(a), t, rho, mu))
        floor = top + t
    return out


def ramp(r: dict[str, Any]) -> list[Box]:
    """The static ramp with its lowest corner at the origin's height, the box on its top face ``at`` up the
    slope from the ramp's centre."""
    a = math.radians(r["angle"])
    L, t, at, mu = r.get("length", 20.0), r.get("thickness", 1.0), r.get("at", 5.0), r["mu"]
    w, h = r.get("width", 1.0), r.get("height", 1.0)
    cx, cy = 0.0, L / 2 * math.sin(a) + t / 2 * math.cos(a)
    normal, along = (-math.sin(a), math.cos(a)), (math.cos(a), math.sin(a))
    up = (t + h) / 2
    return [Box(cx, cy, a, L, t, 1.0, mu, static=True),
            Box(cx + up * normal[0] + at * along[0], cy + up * normal[1] + at * along[1], a, w, h,
                r.get("density", 1.0), mu)]


def read_scene(path: Path, steps: int) -> Scene:
    doc = yaml.safe_load(path.read_text())
    scene = doc["scene"]
    boxes = []
    for key, make in (("ramp", ramp), ("pyramid", pyramid), ("card_house", card_house)):
        if key in scene:
            boxes += make(scene[key])
    dt = doc.get("dt", 1 / 60)
    return Scene(boxes, float(doc.get("gravity", -9.8)), float(Fraction(dt)) if isinstance(dt, str) else float(dt),
                 steps)


Poses = np.ndarray  # (movable boxes, 6): x, y, angle, vx, vy, w after the last step


def drive_pymunk(s: Scene) -> Poses:
    import pymunk

    space = pymunk.Space()
    space.gravity = 0, s.gravity
    space.collision_slop = 0.01
    space.collision_bias = (1 - 0.1) ** 60
    ground = pymunk.Body(body_type=pymunk.Body.STATIC)
    ground.position = 0, -GROUND[1] / 2
    plate = pymunk.Poly.create_box(ground, GROUND)
    plate.collision_type = 1
    space.add(ground, plate)
    own: dict[Any, float] = {}
    bodies = []
    for b in s.boxes:
        body = pymunk.Body(body_type=pymunk.Body.STATIC) if b.static else pymunk.Body(b.mass, b.inertia)
        body.position, body.angle = (b.x, b.y), b.angle
        shape = pymunk.Poly.create_box(body, (b.w, b.h))
        shape.friction = math.sqrt(b.mu)  # Chipmunk multiplies the two shapes' values
        own[shape] = b.mu
        space.add(body, shape)
        if not b.static:
            bodies.append(body)

    def ground_friction(arbiter: Any, space: Any, data: Any) -> None:
        arbiter.friction = own[arbiter.shapes[1]]

    space.on_collision(1, 0, pre_solve=ground_friction)
    for _ in range(s.steps):
        space.step(s.dt)
    return np.array([(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in bodies])


def drive_box2d(s: Scene) -> Poses:
    import Box2D

    skin = Box2D.b2_polygonRadius

    class GroundFriction(Box2D.b2ContactListener):  # type: ignore[misc]
        def PreSolve(self, contact: Any, old: Any) -> None:
            a, b = contact.fixtureA, contact.fixtureB
            if a.body is ground or b.body is ground:
                contact.friction = (b if a.body is ground else a).friction

    listener = GroundFriction()
    world = Box2D.b2World(gravity=(0, s.gravity), contactListener=listener)
    ground = world.CreateStaticBody(position=(0, -GROUND[1] / 2))
    ground.CreateFixture(shape=Box2D.b2PolygonShape(box=(GROUND[0] / 2 - skin, GROUND[1] / 2 - skin)))
    bodies = []
    for b in s.boxes:
        make = world.CreateStaticBody if b.static else world.CreateDynamicBody
        body = make(position=(b.x, b.y), angle=b.angle)
        body.CreateFixture(shape=Box2D.b2PolygonShape(box=(b.w / 2 - skin, b.h / 2 - skin)), friction=b.mu,
                           restitution=0)
        if not b.static:
            body.massData = Box2D.b2MassData(mass=b.mass, center=(0, 0), I=b.inertia)
            bodies.append(body)
    for _ in range(s.steps):
        world.Step(s.dt, 8, 3)
    return np.array([(*b.position, b.angle, *b.linearVelocity, b.angularVelocity) for b in bodies])


def drive_box2d_v3(s: Scene) -> Poses:
    import pyb2d3

    (mu,) = {b.mu for b in s.boxes}  # the scenes driven here have one coefficient: the ground gets it
    world = pyb2d3.World(gravity=(0, s.gravity))
    material = pyb2d3.surface_material(friction=mu, restitution=0.0)
    ground = world.create_static_body(position=(0, -GROUND[1] / 2))
    ground.create_polygon_shape(pyb2d3.shape_def(material=material), pyb2d3.box(GROUND[0] / 2, GROUND[1] / 2))
    bodies = []
    for b in s.boxes:
        make = world.create_static_body if b.static else world.create_dynamic_body
        body = make(position=(b.x, b.y), rotation=b.angle)
        body.create_polygon_shape(pyb2d3.shape_def(material=material), pyb2d3.box(b.w / 2, b.h / 2))
        if not b.static:
            data = body.mass_data
            data.mass, data.rotational_inertia = b.mass, b.inertia
            body.mass_data = data
            bodies.append(body)
    for _ in range(s.steps):
        world.step(s.dt, 4)
    return np.array([(*b.position, b.angle, *b.linear_velocity, b.angular_velocity) for b in bodies])


def drive_mujoco(s: Scene) -> Poses:
    """MuJoCo at its defaults, x-z the plane; the boxes' one coefficient on every geom, the plane's included."""
    import mujoco

    (mu,) = {b.mu for b in s.boxes}
    parts = []
    for b in s.boxes:
        geom = f'<geom type="box" size="{b.w / 2!r} 0.5 {b.h / 2!r}" friction="{mu!r} 0.005 0.0001"'
        if b.static:  # a turn by the box's angle in the x-z plane (z up) is a turn by -angle about y
            parts.append(f'<body pos="{b.x!r} 0 {b.y!r}" euler="0 {-b.angle!r} 0">{geom}/></body>')
        else:
            parts.append(f'<body><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>'
                         f'<joint type="hinge" axis="0 -1 0"/><inertial pos="0 0 0" mass="{b.mass!r}" '
                         f'diaginertia="{b.inertia!r} {b.inertia!r} {b.inertia!r}"/>{geom} mass="0"/></body>')
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><compiler angle="radian"/><option timestep="{s.dt!r}" gravity="0 0 {s.gravity!r}"/>'
        f'<worldbody><geom type="plane" size="0 0 1" friction="{mu!r} 0.005 0.0001"/>{"".join(parts)}'
        f'</worldbody></mujoco>')
    data = mujoco.MjData(model)
    movable = [b for b in s.boxes if not b.static]
    data.qpos[:] = [v for b in movable for v in (b.x, b.y, b.angle)]
    for _ in range(s.steps):
        mujoco.mj_step(model, data)
    return np.concatenate([data.qpos.reshape(-1, 3), data.qvel.reshape(-1, 3)], axis=1)


PLANAR_DRIVERS: dict[str, Callable[[Scene], Poses]] = {
    "pymunk": drive_pymunk, "box2d": drive_box2d, "box2d-v3": drive_box2d_v3, "mujoco": drive_mujoco}
