"""What a bench leaves behind: ``bench.json`` (every record) and ``report.html`` (``stackx.bench.page``), the
page with its pictures embedded, so that it is the one file to open or send.

Each record keeps its error dict whole (``spread``, ``spread_max``, ``unsolved``, ``unsolved_residual`` where
the model measures them); each run on a Pareto front and each winner's row carries its error, ``error_spread``
(its uncertainty, 0 where none) and ``unsolved`` (steps the reference left unsolved).

Between two benches of the same configs only the timings differ in ``bench.json``, and what follows from
them (equal-cost winners, Pareto fronts, the cheapest solver that passes, the plots).
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
from collections.abc import Sequence
from importlib import metadata
from typing import Any

from stackx import __version__
from stackx.output import manifest
from stackx.bench.compare import borderline, matrix, outcomes, why
from stackx.bench.markup import png_uri
from stackx.bench.page import report_html
from stackx.bench.plots import drift_profile_png, rest_height, speed_error_png, trajectories_png
from stackx.bench.snapshots import snapshots
from stackx.bench.result import DEFINITIONS, CaseResult
from stackx.bench.sweep import Record
from stackx.bench.uncertainty import spread, unsolved
from stackx.output.outdir import OutputDir


def config_hash(path: str) -> str:
    """SHA-256 of the config file's bytes: which exact config produced a record (read in chunks, so memory
    stays bounded whatever the file's size)."""
    return manifest.file_sha256(path)


def machine() -> dict[str, Any]:
    from stackx import kernel

    return {"platform": platform.platform(), "machine": platform.machine(), "processor": platform.processor(),
            "cpus": os.cpu_count(), "python": sys.version.split()[0], "compiled_kernels": kernel.enabled()}


def versions(results: Sequence[CaseResult] = ()) -> dict[str, str]:
    """stackx, Python and every dependency, as the manifest records them, matplotlib, which draws the plots, and
    the package of every engine benched (its numbers are that version's)."""
    engines = sorted({d for res in results for p in res.case.plans
                      if (d := getattr(p.solver_cls, "distribution", None))})
    return {"stackx": __version__, **manifest.versions(), "matplotlib": metadata.version("matplotlib"),
            **{d: metadata.version(d) for d in engines}}


def _case_doc(res: CaseResult) -> dict[str, Any]:
    case, run = res.case, res.case.run
    return {
        "name": case.name, "file": case.spec.file, "config_sha256": config_hash(case.spec.file),
        "description": case.spec.description, "boxes": run.scene.size(), "dt": run.dt, "steps": run.steps,
        "gravity": run.gravity, "events": [repr(e) for e in run.scene.events()],
        "criteria": case.section.criteria.model_dump(mode="json"),
        "solvers": {p.solver: {"knob": p.knob, "values": p.values, "config_value": p.own, "applied": p.applied,
                               "not_applicable": p.skipped, "claim_baseline": p.claim} for p in case.plans},
        "left_out": res.left_out,
        "records": [r.as_dict() for r in res.records],
        "pareto": [{"solver": r.solver, "value": r.value, "borderline": borderline(r, res.records),
                    "error": r.error.get("rms"), "error_spread": spread(r.error), "unsolved": unsolved(r.error)}
                   for r in res.front],
        "equal_cost": res.equal_cost,
        "claim": res.claim,
        "shown": [_shown_doc(r) for r in outcomes(res.records)],
    }


def _shown_doc(rec: Record) -> dict[str, Any]:
    """A solver's run as the summary shows it (``compare.chosen``; the cheapest that passed first), with its
    series against time."""
    return {"solver": rec.solver, "knob": rec.knob, "value": rec.value, "passed": rec.passed,
            "us_per_step": rec.us_per_step, "why": "" if rec.passed else why(rec),
            "series": rec.series.as_dict() if rec.series is not None else None}


def bench_json(results: list[CaseResult], command: str, wall_seconds: float) -> str:
    """Every record of every case, with the machine, versions, definitions and the stability matrix."""
    all_records = [r for res in results for r in res.records]
    doc = {
        "command": command, "wall_seconds": wall_seconds, "machine": machine(), "versions": versions(results),
        "definitions": DEFINITIONS,
        "cases": [_case_doc(res) for res in results],
        "matrix": {s: {c: cell.as_dict() for c, cell in row.items()} for s, row in matrix(all_records).items()},
    }
    return json.dumps(_finite(doc), indent=1, allow_nan=False) + "\n"


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: such numbers (a run gone wild) are written as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def pictures(res: CaseResult) -> dict[str, str]:
    """A case's plots as ``data:`` URIs: ``time`` (against time), ``drift`` (where the boxes placed at rest
    ended, on a planar scene) and ``speed`` (speed against error), each when there is something to draw."""
    out = {}
    crit = res.case.section.criteria
    time_png = trajectories_png(res.name, outcomes(res.records), crit.depth_limit, rest_height(res.records),
                                (crit.drift, crit.turn))
    if time_png is not None:
        out["time"] = png_uri(time_png)
    scene = res.case.run.scene
    rests = getattr(scene, "rests", list)()  # a scene plugin of another author may not say which boxes rest
    if rests:
        drift_png = drift_profile_png(res.name, outcomes(res.records), scene.build(), rests, (crit.drift, crit.turn))
        if drift_png is not None:
            out["drift"] = png_uri(drift_png)
    speed_png = speed_error_png(res.name, res.records)
    if speed_png is not None:
        out["speed"] = png_uri(speed_png)
    return out


def write(results: list[CaseResult], out: OutputDir, command: str, wall_seconds: float) -> None:
    """Stage ``bench.json`` and ``report.html`` in ``out`` (held in memory; the bench command switches them into
    its folder, ``stackx.output.folder``)."""
    out.write_text("bench.json", bench_json(results, command, wall_seconds))
    drawn = {res.name: pictures(res) for res in results}
    states = {res.name: snapshots(res) for res in results}
    out.write_text("report.html", report_html(results, drawn, command, wall_seconds, machine(), versions(results),
                                              states))
