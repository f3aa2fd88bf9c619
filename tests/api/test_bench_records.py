"""``api.bench`` returns one type whatever is installed (a list of dicts), with the fields docs/api.md lists,
and ``api.frame`` makes the DataFrame only where pandas is."""

from __future__ import annotations

import re
import sys
import types
from typing import Any

import pytest

from stackx import api
from tests.conftest import CONFIGS, REPO


class FakeFrame:
    """What the fake pandas makes: the records it was given."""

    def __init__(self, records: list[dict[str, Any]]) -> None:
        self.records = records

    @classmethod
    def from_records(cls, records: list[dict[str, Any]]) -> FakeFrame:
        return cls(records)


def _fake_pandas() -> types.ModuleType:
    module = types.ModuleType("pandas")
    module.DataFrame = FakeFrame  # type: ignore[attr-defined]
    return module


@pytest.fixture(scope="module")
def rows() -> list[dict[str, Any]]:
    """A bench of the 5-box stack by the lab solver, with pandas importable."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(sys.modules, "pandas", _fake_pandas())
        return api.bench([CONFIGS / "06-stack.yaml"], solvers=["pgs"])  # type: ignore[no-any-return]


def _documented() -> tuple[list[str], list[str]]:
    """The fields of docs/api.md's table of a bench record: the fixed ones in order, then the column's measures."""
    text = (REPO / "docs" / "api.md").read_text()
    table = text.split("### The fields of a bench record", 1)[1].split("\n## ", 1)[0]
    fixed: list[str] = []
    measures: list[str] = []
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")] if line.startswith("|") else []
        if len(cells) < 2 or cells[0] in ("field", "---"):
            continue
        if cells[0] == "then":
            measures = re.findall(r"`(\w+)`", cells[1].split("; a planar")[0])
        else:
            fixed += re.findall(r"`(\w+)`", cells[0])
    return fixed, measures


def test_bench_returns_a_list_of_dicts_even_with_pandas_installed(rows: list[dict[str, Any]]) -> None:
    assert isinstance(rows, list) and rows and all(type(row) is dict for row in rows)
    assert {row["solver"] for row in rows} == {"pgs"}


def test_every_field_of_a_record_is_documented_in_its_order(rows: list[dict[str, Any]]) -> None:
    fixed, measures = _documented()
    for row in rows:
        keys = list(row)
        assert keys[:len(fixed)] == fixed
        assert sorted(keys[len(fixed):]) == sorted(measures)


def test_frame_hands_the_records_to_pandas(rows: list[dict[str, Any]], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pandas", _fake_pandas())
    made = api.frame(rows)
    assert isinstance(made, FakeFrame) and made.records == rows


def test_frame_without_pandas_says_how_to_get_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas raises ImportError
    with pytest.raises(ImportError, match="api.frame needs pandas, which stackx does not install: pip install "
                                          "pandas"):
        api.frame([{"solver": "pgs"}])
