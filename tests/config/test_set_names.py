"""``--set`` chooses a list item by index or by name: ``outputs[frames].count=all``."""

from __future__ import annotations

import pytest

from stackx.config.experiment import apply_sets, parse_key
from stackx.errors import ConfigError
from stackx.config.yamlsrc import load_file
from tests.conftest import CONFIGS

STACK = str(CONFIGS / "06-stack.yaml")


@pytest.mark.parametrize("key, index", [("outputs[frames].count", 2), ("outputs[f{index:02d}.png].count", 2),
                                        ("outputs[stack.png].count", 1), ("outputs[ metrics ].count", 3),
                                        ("outputs[2].count", 2)])
def test_an_output_by_name_is_the_output_by_index(key: str, index: int) -> None:
    src = apply_sets(load_file(STACK), [f"{key}=7"])
    assert src.data["outputs"][index]["count"] == 7
    assert sum("count" in o and o["count"] == 7 for o in src.data["outputs"]) == 1


def test_an_unknown_name_lists_the_names() -> None:
    with pytest.raises(ConfigError) as info:
        apply_sets(load_file(STACK), ["outputs[frame].count=all"])
    assert str(info.value) == ("--set outputs[frame].count=all: no item of outputs named 'frame'; names: "
                               "[0] keyvalue or 06-stack.txt; [1] stack or stack.png; [2] frames or "
                               "f{index:02d}.png; [3] metrics or 06-stack.metrics.json")


def test_a_name_shared_by_two_outputs_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"2 items \(\[0\], \[1\]\) of outputs named 'keyvalue'"):
        apply_sets(load_file(STACK), ["outputs[1].render=x", "outputs[1].sink=keyvalue",
                                      "outputs[keyvalue].path=a.txt"])


def test_names_only_in_set_keys() -> None:
    assert parse_key("a.b[0].c") == ("a", "b", 0, "c")
    with pytest.raises(ValueError):
        parse_key("outputs[frames].count")  # a run's override or a bench knob indexes by number
