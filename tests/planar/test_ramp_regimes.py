"""What a ramp states its box does, worked here from the forces on a rigid box: it sticks, slides, tips or
pivots, and ``planar-exact`` does it and passes; a config at a boundary between two outcomes is refused at its
line; a box pushed along the ground stops where friction stops it, and a wrong stopping distance fails."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import pytest

from stackx import api
from stackx.bench.criteria import Criteria, failed_words, judge, passed
from stackx.errors import ConfigError
from stackx.models.planar import measures
from stackx.run.session import verdict
from stackx.scenes.planar import Planar, PlanarParams
from tests.conftest import CONFIGS, Cli

G = 9.8
DT = 1 / 60
STEPS = 150  # 2.5 s: long enough for the tall box to go over, short enough to stay on the ramp


def _statics(angle_deg: float, mu: float, width: float, height: float) -> str:
    """What a box released at rest does, from the forces on it (per unit mass, in the slope's frame: x down
    the slope, y out of it). Friction holds it when the pull down the slope, g sin a, is at most what friction
    can give, mu g cos a; else it slides at g sin a - mu g cos a. In the box's own frame (d'Alembert) the net
    of the weight and, when it slides, the inertial force of that acceleration acts at its centre; its moment
    about the downhill corner either presses the base onto the slope (it stays on its base) or lifts the uphill
    edge (it goes over that corner). Friction and the normal force act on the base line through that corner,
    so they have no moment about it."""
    a = math.radians(angle_deg)
    held = G * math.sin(a) <= mu * G * math.cos(a)
    along = 0.0 if held else G * (math.sin(a) - mu * math.cos(a))
    fx, fy = G * math.sin(a) - along, -G * math.cos(a)
    rx, ry = -width / 2, height / 2  # the centre, from the downhill corner
    on_base = rx * fy - ry * fx >= 0  # counter-clockwise about the corner presses the base down
    return {(True, True): "stick", (True, False): "tip", (False, True): "slide", (False, False): "pivot"}[
        (held, on_base)]


CASES = {  # name: (angle in degrees, mu, width, height)
    "stick": (20.0, 0.5, 1.0, 1.0),
    "slide": (35.0, 0.5, 1.0, 1.0),
    "slide-tall": (30.0, 0.2, 0.4, 1.6),  # would tip at rest (w/h < tan 30), but friction is too weak to tip it
    "tip": (16.0, 0.8, 0.4, 1.6),
    "pivot": (30.0, 0.5, 0.4, 1.6),
}


def _ramp(angle: float, mu: float, width: float, height: float) -> dict[str, object]:
    return {"angle": angle, "mu": mu, "width": width, "height": height}


def _run(ramp: dict[str, object], solver: str = "planar-exact", steps: int = STEPS) -> tuple[object, object]:
    spec = api.load(CONFIGS / "planar" / "ramp-stick.yaml",
                    {"scene.ramp": ramp, "solver.name": solver, "steps": steps})
    result = api.run(spec, steps=[0])
    return spec, result.experiment.runs[0]


@pytest.mark.parametrize("name", list(CASES))
def test_the_ramp_states_what_statics_say_and_the_exact_solver_does_it(name: str) -> None:
    angle, mu, width, height = CASES[name]
    expected = _statics(angle, mu, width, height)
    assert expected == name.split("-")[0]  # the case is what its name says, by the forces above
    spec, run = _run(_ramp(angle, mu, width, height))
    slope = run.spec.scene.slope()
    assert slope.regime == expected
    start, end = run.spec.scene.build(), run.final
    a = math.radians(angle)
    turn = end.angle[0, 1] - start.angle[0, 1]
    down = -(end.vx[0, 1] * math.cos(a) + end.vy[0, 1] * math.sin(a))  # velocity down the slope
    if expected == "stick":
        assert abs(end.x[0, 1] - start.x[0, 1]) < 1e-6 and abs(turn) < 1e-6
    elif expected == "slide":
        assert down / (STEPS * DT) == pytest.approx(G * (math.sin(a) - mu * math.cos(a)), abs=1e-6)
        assert abs(turn) < 1e-6 and abs(end.w[0, 1]) < 1e-6  # flat on its base all the way
    else:  # over its downhill corner (towards -x, counter-clockwise) onto its long side
        assert turn == pytest.approx(math.pi / 2, abs=0.02)
    judged = verdict(run, spec.bench)
    assert judged == (True, ""), judged


@pytest.mark.parametrize(("name", "regime"), [
    ("ramp-stick", "stick"), ("ramp-below", "stick"), ("ramp-slide", "slide"), ("ramp-above", "slide"),
    ("ramp-slide-tall", "slide"), ("ramp-tip", "tip"), ("ramp-pivot", "pivot")])
def test_each_shipped_ramp_states_the_outcome_its_name_says(name: str, regime: str) -> None:
    scene = api.load(CONFIGS / "planar" / f"{name}.yaml").runs[0].scene
    r = scene.params.ramp
    assert _statics(r.angle, r.mu, r.width, r.height) == regime == scene.slope().regime


def _judged(scene: Planar, final: object, criteria: Criteria | None = None) -> tuple[bool, str]:
    spec = SimpleNamespace(scene=scene, steps=STEPS, dt=DT, gravity=-G)
    found = measures.bench_measures(SimpleNamespace(spec=spec, final=final, frames={}))  # type: ignore[arg-type]
    found.update({"max_depth": 0.0, "reach": 0.0, "rms_motion": 0.0, "launch": 0.0})
    verdicts = judge(found, criteria or Criteria(), measures.unjudged(scene))
    return passed(verdicts), failed_words(verdicts, found)


@pytest.mark.parametrize("name", ["tip", "pivot"])
def test_a_tall_box_that_stays_on_its_base_where_it_must_go_over_fails_did_not_tip(name: str) -> None:
    scene = Planar(PlanarParams.model_validate({"ramp": _ramp(*CASES[name])}))
    start = scene.build()
    assert _judged(scene, start) == (False, "did not tip")  # it stood still
    a = math.radians(CASES[name][0])
    slid = start.copy()  # slid flat at g (sin a - mu cos a), as a box that ignores its height would
    rate = max(G * (math.sin(a) - CASES[name][1] * math.cos(a)), 0.0) * STEPS * DT
    slid.vx[0, 1], slid.vy[0, 1] = -rate * math.cos(a), -rate * math.sin(a)
    assert _judged(scene, slid) == (False, "did not tip")
    over = start.copy()
    over.angle[0, 1] += math.pi / 2  # lying on its long side
    assert _judged(scene, over) == (True, "")
    uphill = start.copy()
    uphill.angle[0, 1] -= math.pi / 2  # fell the wrong way
    assert _judged(scene, uphill)[0] is False


def test_a_tall_box_that_must_slide_flat_fails_turned_when_it_goes_over() -> None:
    angle, mu, width, height = CASES["slide-tall"]
    scene = Planar(PlanarParams.model_validate({"ramp": _ramp(angle, mu, width, height)}))
    start = scene.build()
    a = math.radians(angle)
    rate = G * (math.sin(a) - mu * math.cos(a)) * STEPS * DT  # the right speed down the slope
    flat = start.copy()
    flat.vx[0, 1], flat.vy[0, 1] = -rate * math.cos(a), -rate * math.sin(a)
    assert _judged(scene, flat) == (True, "")
    over = flat.copy()
    over.angle[0, 1] += math.pi / 2  # as fast, but on its side: it pivoted where it should have slid
    assert _judged(scene, over) == (False, "turned")


CONFIG = """\
description: a box at a boundary between two outcomes
scene:
  name: planar
  ramp: {RAMP}
solver: {name: planar-exact}
gravity: -9.8
dt: 1/60
steps: 10
"""


@pytest.mark.parametrize(("ramp", "words"), [
    ({"angle": 26.4, "mu": 0.5}, "sticks or slides"),  # tan 26.4 = 0.496
    ({"angle": 14.3, "mu": 0.8, "width": 0.4, "height": 1.6}, "stands or tips"),  # tan 14.3 = 0.255 vs 0.25
    ({"angle": 30.0, "mu": 0.252, "width": 0.4, "height": 1.6}, "slides flat or pivots"),
])
def test_a_ramp_at_a_boundary_is_refused_at_its_line(tmp_path: Path, ramp: dict[str, float], words: str) -> None:
    path = tmp_path / "edge.yaml"
    path.write_text(CONFIG.replace("{RAMP}", "{" + ", ".join(f"{k}: {v}" for k, v in ramp.items()) + "}"))
    with pytest.raises(ConfigError) as caught:
        api.load(path)
    err = caught.value
    assert (err.file, err.line, err.col, err.key) == (str(path), 4, 9, "scene.ramp")
    assert words in err.message and "not decided" in err.message


def test_the_cli_refuses_an_undecided_ramp_with_exit_2_and_writes_nothing(cli: Cli, tmp_path: Path) -> None:
    out = tmp_path / "out"
    done = cli("run", CONFIGS / "planar" / "ramp-tip.yaml", "--set", "scene.ramp.angle=14.3", "--out", out)
    assert done.returncode == 2
    assert "ramp-tip.yaml:7:9: scene.ramp: tan(angle) = 0.2549 is within 2% of the box's width/height" in done.stderr
    assert "Traceback" not in done.stderr and not out.exists()


def test_a_run_long_enough_to_slide_the_box_off_the_ramp_is_refused_at_steps() -> None:
    """ramp-slide-tall's box (30 degrees, mu 0.2, 0.4 m wide, 5 m up a 20 m ramp) reaches the lower end once
    g (sin a - mu cos a) t^2 / 2 passes 5 + 10 - 0.2 m: the last step count that keeps it on is accepted, the next
    refused where the config sets `steps`, since past the end its stated slide would fail every solver."""
    a = 9.8 * (math.sin(math.radians(30)) - 0.2 * math.cos(math.radians(30)))
    last = math.floor(math.sqrt(2 * (5 + 10 - 0.2) / a) * 60)  # steps of 1/60 s still on the ramp
    path = CONFIGS / "planar" / "ramp-slide-tall.yaml"
    assert api.load(path, {"steps": last}).runs[0].steps == last
    with pytest.raises(ConfigError) as caught:
        api.load(path, {"steps": last + 1})
    assert caught.value.key == "steps" and "past the ramp's lower end" in caught.value.message


def _braked(speed: float, mu: float, dt: float, *, explicit: bool = False) -> float:
    """The distance a box braked by Coulomb friction covers, stepped here one step at a time: each step takes
    mu g dt off its speed (never below 0) and moves it by the new speed (or, ``explicit``, by the old one)."""
    x, v = 0.0, speed
    while v > 0:
        braked = max(v - mu * G * dt, 0.0)
        x += (v if explicit else braked) * dt
        v = braked
    return x


def _skid(speed: float = 3.0, mu: float = 0.5) -> Planar:
    return Planar(PlanarParams.model_validate({"skid": {"speed": speed, "mu": mu}}))


def test_a_skid_states_the_distance_of_the_models_steps_and_of_v2_over_2_mu_g() -> None:
    stop = _skid().stop()
    assert stop is not None and stop.box == 0
    assert stop.stepped(-G, DT) == pytest.approx(_braked(3.0, 0.5, DT), abs=1e-12)
    assert stop.stepped(-G, DT / 1000) == pytest.approx(9.0 / (2 * 0.5 * G), rel=1e-3)  # small steps: v^2/(2 mu g)
    assert stop.distance(-G) == 9.0 / (2 * 0.5 * G)


def test_the_exact_solver_stops_a_skid_where_its_steps_say_and_passes() -> None:
    spec = api.load(CONFIGS / "planar" / "skid.yaml", {"solver.name": "planar-exact"})
    run = api.run(spec, steps=[0]).experiment.runs[0]
    assert run.final.x[0, 0] - run.spec.scene.build().x[0, 0] == pytest.approx(_braked(3.0, 0.5, DT), abs=1e-9)
    assert verdict(run, spec.bench) == (True, "")


@pytest.mark.parametrize(("distance", "ok"), [
    (_braked(3.0, 0.5, DT), True),                    # the model's steps
    (9.0 / (2 * 0.5 * G), True),                      # v^2 / (2 mu g): smaller steps
    (_braked(3.0, 0.5, DT, explicit=True), False),    # moved by the old speed: 3% long
    (_braked(3.0, 0.55, DT), False),                  # braked 10% too hard: short
])
def test_a_stopping_distance_outside_the_steps_and_v2_over_2_mu_g_fails_stops_wrong(distance: float,
                                                                                   ok: bool) -> None:
    scene = _skid()
    final = scene.build()
    final.x[0, 0] += distance
    final.vx[0, 0] = 0.0
    assert _judged(scene, final) == ((True, "") if ok else (False, "stops wrong"))
    assert _judged(scene, final, Criteria(stops=0.2)) == (True, "")  # the config's tolerance, stated wider


def test_an_engine_stepping_positions_by_the_old_speed_stops_long_and_fails() -> None:
    pytest.importorskip("pymunk")
    spec = api.load(CONFIGS / "planar" / "skid.yaml", {"solver.name": "pymunk"})
    run = api.run(spec, steps=[0]).experiment.runs[0]
    went = run.final.x[0, 0] - run.spec.scene.build().x[0, 0]
    assert went > 1.02 * 9.0 / (2 * 0.5 * G)
    judged = verdict(run, spec.bench)
    assert judged is not None and judged[0] is False and judged[1].startswith("stops wrong")


@pytest.mark.parametrize("mu", [0.26, 0.4])
def test_a_skid_that_would_pivot_on_its_leading_edge_is_refused(mu: float) -> None:
    with pytest.raises(ValueError, match="pivot on its leading edge"):
        PlanarParams.model_validate({"skid": {"speed": 3.0, "mu": mu, "width": 0.4, "height": 1.6}})
