"""``stackx bench`` over two small planar cases: the matrix and the report, judged by the checks each case can
fail (a sliding box is not judged settled; a ramp is judged on its slide), the reference passing."""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import CONFIGS, Cli


def test_bench_runs_planar_cases_end_to_end(cli: Cli, tmp_path: Path) -> None:
    cases = [CONFIGS / "planar" / f"{n}.yaml" for n in ("ramp-stick", "ramp-slide")]
    done = cli("bench", *cases, "--solvers", "planar-pgs,planar-exact", "--out", tmp_path, "--set", "steps=30",
               "--set", "bench.knob=[1,8]", "--set", "bench.timing.steps=10", "--set", "bench.timing.repeats=1",
               timeout=300)
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "bench.json").read_text())
    assert [c["name"] for c in doc["cases"]] == ["ramp-stick", "ramp-slide"]
    assert set(doc["matrix"]) == {"planar-pgs", "planar-exact"}
    for case in doc["cases"]:
        assert case["boxes"] == 2 and case["steps"] == 30
        runs = {(r["solver"], r["value"]) for r in case["records"]}
        assert runs == {("planar-pgs", 1), ("planar-pgs", 8), ("planar-pgs", 15), ("planar-exact", None)}
        for r in case["records"]:
            holds = [c["measure"] for c in r["criteria"]["holds"]["checks"]]
            settled = [c["measure"] for c in r["criteria"]["settled"]["checks"]]
            if case["name"] == "ramp-stick":  # the box should stay: drift judged, and it must settle
                assert holds == ["max_depth", "reach", "drift_x", "drift_angle", "slide_error"]
                assert settled == ["rms_motion"]
            else:  # it slides: no drift, no settling, the acceleration against g (sin a - mu cos a)
                assert holds == ["max_depth", "reach", "slide_error", "slide_turn"] and settled == []
                assert abs(r["measures"]["slide_acceleration"] - 9.8 * (0.573576436 - 0.5 * 0.819152044)) < \
                    r["measures"]["slide_error"] + 1e-8
            assert r["criteria"]["never_launched"]["checks"][0]["measure"] == "launch"
        exact = next(r for r in case["records"] if r["solver"] == "planar-exact")
        assert exact["reference"] and exact["passed"]
        assert exact["error"]["rms"] < 1e-9  # measured every step against the reference: itself
        assert all(r["error"]["steps"] == 30 for r in case["records"])
        # every step's own answer checked beside the error: the exact one breaks no condition
        assert all(r["error"]["violation_steps"] == 30 for r in case["records"])
        assert max(exact["error"]["violation_max"].values()) < 1e-9 and exact["error"]["approach_max"] < 1e-9
        assert exact["measures"]["slide_error"] < 1e-6
        assert doc["matrix"]["planar-exact"][case["name"]]["passed"]
    page = (tmp_path / "report.html").read_text()
    assert "ramp-stick" in page and "ramp-slide" in page and "not judged" in page
    assert "drift_x" in page and "slide_error" in page  # the definitions printed with the report
    assert "own answer: largest violation (m/s)" in page and "complementarity" in page
