"""JSON Schema of a config file, with the parameters of every installed plugin spliced in."""

from __future__ import annotations

from typing import Any

from stackx import registry
from stackx.config.experiment import ExperimentModel


def _plugin_schemas(reg: registry.Registry[Any], key: str, defs: dict[str, Any]) -> list[dict[str, Any]]:
    out = []
    for entry in reg.entries():
        cls = reg.get(entry.name)
        schema = cls.Params.model_json_schema(ref_template="#/$defs/{model}")
        defs.update(schema.pop("$defs", {}))
        schema.setdefault("properties", {})[key] = {"const": entry.name}
        schema["required"] = sorted({key, *schema.get("required", [])})
        schema["title"] = f"{reg.kind} {entry.name}"
        schema["description"] = (cls.__doc__ or "").strip()
        out.append(schema)
    return out


def config_schema() -> dict[str, Any]:
    schema = ExperimentModel.model_json_schema(ref_template="#/$defs/{model}")
    defs = schema.setdefault("$defs", {})
    props = schema["properties"]
    props["scene"] = {"description": props["scene"].get("description", ""),
                      "oneOf": _plugin_schemas(registry.scenes, "name", defs)}
    props["solver"] = {"description": props["solver"].get("description", ""),
                       "oneOf": _plugin_schemas(registry.solvers, "name", defs)}
    props["outputs"] = {"description": props["outputs"].get("description", ""), "type": "array",
                        "items": {"oneOf": _plugin_schemas(registry.sinks, "sink", defs)
                                  + _plugin_schemas(registry.renderers, "render", defs)}}
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "stackx experiment config"
    return schema
