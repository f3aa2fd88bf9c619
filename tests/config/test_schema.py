"""``stackx schema`` as an editor uses it: every shipped config passes it, and a typo does not."""

from __future__ import annotations

import copy
import json
from typing import Any

import pytest
import yaml
from jsonschema import Draft202012Validator

from stackx.config.experiment import ExperimentModel
from tests.conftest import REPO, run_cli

SHIPPED = sorted(REPO.glob("configs/**/*.yaml"))


@pytest.fixture(scope="module")
def validator(tmp_path_factory: pytest.TempPathFactory) -> Draft202012Validator:
    """The schema printed by the command, with the repository's local plugin (the example config needs it)."""
    target = tmp_path_factory.mktemp("schema") / "schema.json"
    done = run_cli("schema", "--plugins", REPO / "plugins", "--out", target)
    assert done.returncode == 0, done.stderr
    schema = json.loads(target.read_text())
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def _errors(validator: Draft202012Validator, doc: Any) -> list[str]:
    return [f"{'.'.join(map(str, e.absolute_path))}: {e.message}" for e in validator.iter_errors(doc)]


def test_every_shipped_config_passes(validator: Draft202012Validator) -> None:
    assert len(SHIPPED) >= 20
    failures = {p.relative_to(REPO).as_posix(): _errors(validator, yaml.safe_load(p.read_text())) for p in SHIPPED}
    assert {name: errs for name, errs in failures.items() if errs} == {}


def test_an_editor_reading_yaml_1_2_sees_off_as_a_word(validator: Draft202012Validator) -> None:
    """YAML 1.1 (PyYAML, stackx's loader) reads ``correction: off`` as false, YAML 1.2 language servers as the
    string 'off': both pass, and both mean what the loader makes of them (no correction)."""
    doc = yaml.safe_load((REPO / "configs" / "03-sink.yaml").read_text())
    assert doc["solver"]["correction"] is False
    doc["solver"]["correction"] = "off"
    assert _errors(validator, doc) == []
    doc["solver"]["correction"] = "of"
    assert _errors(validator, doc)


@pytest.mark.parametrize("path, value", [
    (("step",), 900),                                  # steps
    (("solver", "iteratons"), 10),                     # iterations
    (("solver", "correction", "slp"), 0.01),           # slop
    (("scene", "stak"), {"count": 2}),                 # stack
    (("outputs", 0, "pth"), "06-stack.txt"),           # path
    (("bench", "knobz"), {"pgs": [1, 2]}),             # knobs
])
def test_a_typo_fails(validator: Draft202012Validator, path: tuple[Any, ...], value: Any) -> None:
    base = yaml.safe_load((REPO / "configs" / "06-stack.yaml").read_text())
    base["bench"] = {"knob": [1, 2]}
    base["solver"]["correction"] = {"slop": 0.01, "percent": 0.2}
    assert _errors(validator, base) == []
    doc = copy.deepcopy(base)
    here = doc
    for key in path[:-1]:
        here = here[key]
    here[path[-1]] = value
    assert _errors(validator, doc), f"{'.'.join(map(str, path))} should be refused"


@pytest.mark.parametrize("dt, ok", [
    ("1/60", True), (" 1 / 60 ", True), ("2.5/150", True), ("1./30", True), (0.01, True), (1, True),
    ("1/sixty", False), ("1//60", False), ("-1/60", False), ("1/-60", False), (0, False), (-0.01, False),
    (11, False), ("sixty", False),
])
def test_dt_forms_agree_with_the_loader(validator: Draft202012Validator, dt: Any, ok: bool) -> None:
    """What the schema accepts for ``dt`` is what the config model accepts, for fractions and numbers."""
    assert (_errors(validator, {"dt": dt}) == []) is ok
    try:
        ExperimentModel.model_validate({"dt": dt})
        loaded = True
    except ValueError:
        loaded = False
    assert loaded is ok
