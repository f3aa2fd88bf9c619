"""The planar scene: generated boxes where hand geometry puts them, masses from sizes, same seed same bytes,
and bad input refused with one located line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from stackx import api
from stackx.errors import ConfigError
from stackx.scenes.planar import Planar, PlanarParams
from tests.conftest import Cli


def _scene(**section: object) -> Planar:
    return Planar(PlanarParams.model_validate(section))


def _corners(x: float, y: float, angle: float, hx: float, hy: float) -> list[tuple[float, float]]:
    """The four corners of a box, rotated by hand."""
    c, s = math.cos(angle), math.sin(angle)
    return [(x + c * px - s * py, y + s * px + c * py) for px, py in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))]


def test_a_stack_is_placed_box_on_box_with_seeded_offsets_and_masses_from_density() -> None:
    s = _scene(stack={"count": 3, "x": 2.0, "width": 1.0, "height": 0.5, "gap": 0.01, "offset": 0.1, "seed": 7,
                      "density": 3.0, "friction": 0.4}).build()
    shifts = np.random.default_rng(7).uniform(-0.1, 0.1, 3)
    assert s.x[0].tolist() == (2.0 + shifts).tolist()
    assert s.y[0].tolist() == pytest.approx([0.25 + 0.01, 0.75 + 0.02, 1.25 + 0.03], abs=1e-15)
    mass = 3.0 * 1.0 * 0.5
    assert s.inv_mass[0].tolist() == pytest.approx([1 / mass] * 3)
    assert s.inv_inertia[0].tolist() == pytest.approx([12 / (mass * (1.0 + 0.25))] * 3)
    assert s.hx[0].tolist() == [0.5] * 3 and s.hy[0].tolist() == [0.25] * 3
    assert s.friction[0].tolist() == [0.4] * 3 and s.angle[0].tolist() == [0.0] * 3


def test_the_same_seed_gives_the_same_bytes_and_another_seed_another_stack() -> None:
    section = {"count": 20, "offset": 0.05, "seed": 11}
    a, b = _scene(stack=section).build(), _scene(stack=section).build()
    assert all(getattr(a, k).tobytes() == getattr(b, k).tobytes() for k in a.BODY)
    c = _scene(stack={**section, "seed": 12}).build()
    assert a.x.tobytes() != c.x.tobytes()
    assert np.abs(a.x).max() <= 0.05


def test_a_thrown_box_starts_above_the_stack_falling_and_is_the_top() -> None:
    scene = _scene(stack={"count": 4, "thrown": {"speed": 20.0, "gap": 0.5, "density": 2.0}})
    s = scene.build()
    assert s.y[0, -1] == 4.0 + 0.5 + 0.5 and s.vy[0, -1] == -20.0
    assert s.inv_mass[0, -1] == 0.5
    assert scene.rests() == [0, 1, 2, 3]  # the thrown box moves: its drift is not judged
    assert scene.rest_top() == (4, 4.5, 5)


def test_a_pyramid_puts_each_box_over_two_below_it() -> None:
    scene = _scene(pyramid={"rows": 3, "gap": 0.1, "x": 1.0})
    s = scene.build()
    expected = [(-0.1, 0.5), (1.0, 0.5), (2.1, 0.5), (0.45, 1.5), (1.55, 1.5), (1.0, 2.5)]
    assert s.x[0].tolist() == pytest.approx([x for x, _ in expected], abs=1e-15)
    assert s.y[0].tolist() == pytest.approx([y for _, y in expected], abs=1e-15)
    assert scene.rest_top() == (5, 2.5, 3) and scene.size() == 6 == s.bodies


def test_heavy_on_light_is_ratio_times_heavier_on_top() -> None:
    scene = _scene(heavy_on_light={"ratio": 1000.0, "light": 2, "density": 2.0})
    s = scene.build()
    assert (1 / s.inv_mass[0]).tolist() == pytest.approx([2.0, 2.0, 2000.0])
    assert s.y[0].tolist() == [0.5, 1.5, 2.5]
    assert scene.rest_top() == (2, 2.5, 3)


@pytest.mark.parametrize(("angle", "mu", "sticks"), [(20.0, 0.5, True), (35.0, 0.5, False)])
def test_a_ramp_box_starts_flat_on_the_static_ramp(angle: float, mu: float, sticks: bool) -> None:
    scene = _scene(ramp={"angle": angle, "mu": mu, "length": 10.0, "thickness": 0.4, "at": 2.0, "width": 1.0,
                         "height": 0.6})
    s = scene.build()
    a = math.radians(angle)
    assert s.inv_mass[0, 0] == 0.0 and s.inv_inertia[0, 0] == 0.0  # the ramp never moves
    assert s.angle[0].tolist() == [a, a] and s.friction[0].tolist() == [mu, mu]
    ramp = _corners(s.x[0, 0], s.y[0, 0], a, 5.0, 0.2)
    assert min(c[1] for c in ramp) == pytest.approx(0.0, abs=1e-12)  # its lowest corner on the ground
    normal, along = (-math.sin(a), math.cos(a)), (math.cos(a), math.sin(a))
    top = (ramp[0][0], ramp[0][1])  # a corner of its top face
    bottom = _corners(s.x[0, 1], s.y[0, 1], a, 0.5, 0.3)[2:]
    for px, py in bottom:  # the box's bottom corners lie on the ramp's top face
        assert (px - top[0]) * normal[0] + (py - top[1]) * normal[1] == pytest.approx(0.0, abs=1e-12)
    centre = (s.x[0, 1] - s.x[0, 0]) * along[0] + (s.y[0, 1] - s.y[0, 0]) * along[1]
    assert centre == pytest.approx(2.0, abs=1e-12)
    slope = scene.slope()
    assert slope is not None and slope.box == 1 and slope.sticks is sticks
    assert slope.acceleration(-9.8) == (0.0 if sticks else pytest.approx(9.8 * (math.sin(a) - mu * math.cos(a))))
    assert scene.rests() == ([1] if sticks else [])
    assert scene.rest_top() is None


def test_a_card_house_leans_its_cards_corner_to_corner_on_the_ground() -> None:
    scene = _scene(card_house={"pairs": 2, "levels": 2, "length": 1.0, "thickness": 0.05, "angle": 20.0})
    s = scene.build()
    assert s.bodies == scene.size() == 7  # 2 pairs + 1 flat card, then 1 pair
    a, L, t = math.radians(20.0), 1.0, 0.05
    cards = [_corners(s.x[0, i], s.y[0, i], s.angle[0, i], s.hx[0, i], s.hy[0, i]) for i in range(7)]
    for left, right in ((0, 1), (2, 3)):
        assert s.angle[0, left] == -a and s.angle[0, right] == a
        assert min(y for _, y in cards[left]) == pytest.approx(0.0, abs=1e-12)
        assert min(y for _, y in cards[right]) == pytest.approx(0.0, abs=1e-12)
        inner_left = max(sorted(cards[left], key=lambda c: c[1])[2:])  # of the two top corners, the inner one
        inner_right = min(sorted(cards[right], key=lambda c: c[1])[2:])
        assert list(inner_left) == pytest.approx(list(inner_right), abs=1e-12)
        assert inner_left[1] == pytest.approx(L * math.cos(a), abs=1e-12)
    flat_bottom = s.y[0, 4] - s.hy[0, 4]
    assert flat_bottom == pytest.approx(L * math.cos(a) + t * math.sin(a), abs=1e-12)  # on the highest corners
    assert max(y for c in cards[:4] for _, y in c) == pytest.approx(flat_bottom, abs=1e-12)
    for card in (5, 6):  # the upper pair stands on the flat card
        assert min(y for _, y in cards[card]) == pytest.approx(flat_bottom + t, abs=1e-12)
    assert scene.rests() == list(range(7)) and scene.rest_top() is None


def test_listed_boxes_take_mass_inertia_static_and_come_after_generated_ones() -> None:
    scene = _scene(stack={"count": 2}, boxes=[
        {"x": 3.0, "y": 0.5, "angle": 90.0, "width": 2.0, "height": 1.0, "mass": 4.0},
        {"x": 6.0, "y": 1.0, "mass": 2.0, "inertia": 0.5, "vx": -1.0, "w": 2.0},
        {"x": 9.0, "y": 1.0, "static": True, "rests": True}])
    s = scene.build()
    assert s.bodies == scene.size() == 5
    assert s.angle[0, 2] == pytest.approx(math.pi / 2)
    assert 1 / s.inv_inertia[0, 2] == pytest.approx(4.0 * (4.0 + 1.0) / 12)
    assert s.inv_inertia[0, 3] == 2.0 and s.vx[0, 3] == -1.0 and s.w[0, 3] == 2.0
    assert s.inv_mass[0, 4] == 0.0 and s.inv_inertia[0, 4] == 0.0
    assert 1 / s.inv_mass[0, 0] == 1.0  # the default density, 1 kg/m^2, of a 1 m box
    assert scene.rests() == [0, 1]  # generated boxes rest; listed ones only when said (a static one never drifts)
    assert scene.rest_top() is None  # listed boxes are anywhere: no rigid pile to compare with


BAD = [
    ("stack: {count: 5, offset: 0.6}", "scene.stack", "offset 0.6 must be below half the width (0.5)"),
    ("boxes:\n    - {y: 1, wdth: 2}", "scene.boxes[0].wdth", "unknown key 'wdth'; allowed: angle, density"),
    ("boxes:\n    - {y: 1, mass: 2, density: 3}", "scene.boxes[0]", "give density or mass, not both"),
    ("boxes:\n    - {y: 1, static: true, vx: 2}", "scene.boxes[0]", "a static box cannot move"),
    ("ramp: {angle: 95, mu: 0.5}", "scene.ramp.angle", "less than 90"),
    ("ramp: {angle: 30, mu: 0.5, at: 9.8}", "scene.ramp", "must start on the ramp"),
    ("card_house: {pairs: 1, levels: 2}", "scene.card_house", "levels (2) cannot exceed pairs (1)"),
    ("pyramid: {rows: 0}", "scene.pyramid.rows", "greater than 0"),
    ("name2: 1", "scene.name2", "unknown key 'name2'"),
]


def _config(tmp_path: Path, section: str) -> tuple[Path, str]:
    text = f"scene:\n  name: planar\n  {section}\nsolver: {{name: planar-pgs}}\ndt: 1/60\nsteps: 10\n"
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    return config, text


@pytest.mark.parametrize(("section", "key", "message"), BAD)
def test_bad_scene_input_is_one_line_naming_the_file_line_column_and_key(tmp_path: Path, section: str, key: str,
                                                                         message: str) -> None:
    config, text = _config(tmp_path, section)
    with pytest.raises(ConfigError) as caught:
        api.load(config)
    line = str(caught.value)
    assert "\n" not in line and line.startswith(f"{config}:")
    row, col = (int(v) for v in line[len(f"{config}:"):].split(":")[:2])
    first = key.split(".")[1].split("[")[0]
    assert row >= next(i for i, t in enumerate(text.splitlines()) if first in t) + 1 and col >= 1
    assert f" {key}: " in line and message in line, line


def test_bad_scene_input_exits_2_with_nothing_written(cli: Cli, tmp_path: Path) -> None:
    config, _ = _config(tmp_path, BAD[0][0])
    done = cli("run", config, "--out", tmp_path / "out")
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip() == (f"error: {config}:3:10: scene.stack: offset 0.6 must be below half the width "
                                   "(0.5): neighbours must overlap to rest on each other")
    assert not (tmp_path / "out").exists()


def test_a_scene_without_boxes_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "empty.yaml"
    config.write_text("scene:\n  name: planar\nsolver: {name: planar-pgs}\ndt: 1/60\nsteps: 10\n")
    with pytest.raises(ConfigError) as caught:
        api.load(config)
    assert str(caught.value) == (f"{config}:2:3: scene: no boxes: list 'boxes' or give a generator "
                                 "(ramp, stack, pyramid, card_house, heavy_on_light, dominoes, wall, skid)")
