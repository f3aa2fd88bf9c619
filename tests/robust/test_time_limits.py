"""The limits tests put on what they wait for scale with ``STACKX_TEST_TIME_SCALE``, and 0 removes them."""

from __future__ import annotations

import pytest

from tests.limits import SCALE_ENV, hang_limit


def test_a_limit_is_ten_idle_runs_by_default(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(SCALE_ENV, raising=False)
    assert hang_limit(120) == 1200


def test_the_scale_is_set_by_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(SCALE_ENV, "2.5")
    assert hang_limit(120) == 300
    monkeypatch.setenv(SCALE_ENV, "0")
    assert hang_limit(120) is None


@pytest.mark.parametrize("text", ["fast", "-1", "nan", "inf"])
def test_a_scale_that_is_not_a_number_at_least_0_names_the_variable(monkeypatch: pytest.MonkeyPatch,
                                                                   text: str) -> None:
    monkeypatch.setenv(SCALE_ENV, text)
    with pytest.raises(ValueError, match=f"STACKX_TEST_TIME_SCALE={text!r}: a number >= 0"):
        hang_limit(120)
