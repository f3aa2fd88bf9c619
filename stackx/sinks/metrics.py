"""A JSON file with every measure of every run, for tools and later comparison.

It holds only deterministic numbers; wall-clock times go to the output folder's ``timing.json``.
"""

from __future__ import annotations

import json

from pydantic import BaseModel, ConfigDict, Field

from stackx.outputs import Sink
from stackx.registry import sinks


class MetricsParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    path: str = Field(description="JSON file to write, e.g. 06-stack.metrics.json")


@sinks.register("metrics")
class Metrics(Sink):
    """Every measure of every run as JSON (deterministic; no timings)."""

    Params = MetricsParams

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        doc = {
            "config": result.spec.name,
            "runs": {r.name: {"solver": r.spec.solver_cls.plugin_name, "boxes": r.spec.scene.final_size(),
                              "steps": r.spec.steps, "dt": r.spec.dt, **r.measures} for r in result.runs},
        }
        out.write_text(self.params.path, json.dumps(doc, indent=2, sort_keys=True) + "\n")
