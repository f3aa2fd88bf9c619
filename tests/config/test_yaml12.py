"""Plain scalars read by the YAML 1.2 core schema; explicit tags other than the plain ones refused where written."""

from __future__ import annotations

import math

import pytest

from stackx.errors import ConfigError
from stackx.config.yamlsrc import load_text


@pytest.mark.parametrize("text, value", [
    ("1:30", "1:30"),  # YAML 1.1 read this as 90 (base 60)
    ("010", 10),  # YAML 1.1: 8 (octal)
    ("0x1F", "0x1F"), ("0o17", "0o17"), ("0b101", "0b101"),
    ("yes", "yes"), ("on", "on"), ("No", "No"),
    ("2001-12-14", "2001-12-14"),  # YAML 1.1: a date
    ("1e3", 1000.0),  # YAML 1.1 (PyYAML): the text "1e3"
    ("100_000", 100000), ("-7", -7), ("+7", 7), ("1.", 1.0), (".5", 0.5), ("-2.5e-3", -0.0025),
    ("true", True), ("FALSE", False), ("~", None), ("null", None), ("", None),
    ("!!str 12", "12"), ("!!float 3", 3.0), ("!!int 12", 12),
])
def test_plain_scalars_are_yaml_1_2(text: str, value: object) -> None:
    got = load_text(f"a: {text}\n", "c.yaml").data["a"]
    assert got == value and type(got) is type(value)


def test_special_floats() -> None:
    data = load_text("a: .inf\nb: -.Inf\nc: .NaN\n", "c.yaml").data
    assert data["a"] == math.inf and data["b"] == -math.inf and math.isnan(data["c"])


@pytest.mark.parametrize("text, words", [
    ("!!int x", "whole number"), ("!!bool maybe", "true or false"), ("!!float ten", "not a number"),
    ("!!null 0", "null"), ("!!binary aGk=", "tag '!!binary'"), ("!!timestamp 2001-12-14", "tag '!!timestamp'"),
    ("!custom 5", "tag '!custom'"), ("!!python/name:os.system", "tag"), ("9" * 101, "101 digits"),
    ("!!float " + "9" * 400, "400 digits"),
])
def test_refused_at_the_value(text: str, words: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_text(f"x: 1\nkey: {text}\n", "c.yaml")
    err = info.value
    assert (err.line, err.col, err.key) == (2, 6, "key")
    assert words in err.message


def test_a_hundred_digits_are_read() -> None:
    assert load_text("a: " + "9" * 100, "c.yaml").data["a"] == 10**100 - 1


def test_nesting_and_size_are_bounded() -> None:
    with pytest.raises(ConfigError, match="nested more than"):
        load_text("a: " + "[" * 100 + "]" * 100, "c.yaml")
    with pytest.raises(ConfigError, match="at most 200,000 YAML values"):
        load_text("a: [" + ", ".join(["1"] * 200_001) + "]", "c.yaml")
