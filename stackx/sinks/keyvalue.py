"""``key=value`` text files, one line per key in the order the config lists them.

Values are expressions over the runs' measures (see ``stackx.config.expr``) and are written with Python's
``repr``, the shortest decimal that reads back as the same float.
"""

from __future__ import annotations

import re

from pydantic import BaseModel, ConfigDict, Field, field_validator

from stackx.errors import RunError
from stackx.config.expr import ExprError, Known, evaluate
from stackx.outputs import Sink
from stackx.registry import sinks

KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""What a key may be: an identifier. A line of the file is then ``name=number`` and nothing else, whatever the
config holds, so the file reads back as data (and is never, say, a line of code)."""


def _shown(key: str) -> str:
    """A key for an error line: quoted, cut to a readable length."""
    return repr(key) if len(key) <= 40 else repr(key[:37]) + "..."


class KeyValueParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    path: str = Field(description="text file to write")
    values: dict[str, str] = Field(min_length=1, description="key -> expression, e.g. y1: y[0], "
                                   "improved: sink.depth[0] - fixed.depth[0]; a key is an identifier",
                                   json_schema_extra={"propertyNames": {"pattern": f"^{KEY.pattern}$"}})

    @field_validator("values", mode="before")
    @classmethod
    def _as_text(cls, values: object) -> object:
        if isinstance(values, dict):
            return {k: str(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                    for k, v in values.items()}
        return values


@sinks.register("keyvalue")
class KeyValue(Sink):
    """key=value lines, each value an expression over the runs' measures."""

    Params = KeyValueParams

    def _runs(self, spec) -> dict[str, Known]:  # type: ignore[no-untyped-def]
        return {r.name: Known(r.scene.final_size(), r.model.SCALARS, r.model.VECTORS) for r in spec.runs}

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        runs = self._runs(spec)
        for key, text in self.params.values.items():
            if not KEY.fullmatch(key):
                raise fail(("values", key), f"key {_shown(key)} is not an identifier: letters, digits and _, not "
                                            "starting with a digit (e.g. max_depth)")
            try:
                evaluate(text, runs)
            except ExprError as exc:
                raise fail(("values", key), str(exc)) from None

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        runs, measures = self._runs(result.spec), {r.name: r.measures for r in result.runs}
        lines = []
        for key, text in self.params.values.items():
            try:
                lines.append(f"{key}={evaluate(text, runs, measures)!r}")
            except ExprError as exc:  # what the measures decide: a division by a measure that came out 0
                raise RunError(f"{self.params.path}: value {key!r}: {exc}") from None
        out.write_text(self.params.path, "\n".join(lines) + "\n")
