"""Output paths are portable relative paths, templates are small, and two outputs never need one place."""

from __future__ import annotations

import pytest

from stackx.outputs import clashes, path_problem, template_problem


@pytest.mark.parametrize("name", ["a.txt", "sub/a.txt", "é/箱.png", "f00.png", "a b.txt", "/".join(["d"] * 15) + "/x",
                                  "n" * 255])
def test_portable_paths_pass(name: str) -> None:
    assert path_problem(name) is None


@pytest.mark.parametrize("name, words", [
    ("", "non-empty"), (".", "'.'"), ("sub/.", "'.'"), ("..", "'..'"), ("a//b", "empty folder name"),
    ("/abs", "empty folder name"), ("a/", "empty folder name"), ("n" * 256, "256 bytes"), ("é" * 128, "256 bytes"),
    ("/".join(["d"] * 17), "17 folders deep"), ("d/" * 600 + "x", "bytes long"), ("a\udc80.txt", "surrogate"),
    ("a\\b", "'\\\\'"), ("a:b", "':'"), ("a?", "'?'"), ("a\x01", "'\\x01'"), ("trail.", "ending in '.'"),
    ("CON", "device name"), ("sub/aux.txt", "device name"),
])
def test_unportable_paths_are_refused(name: str, words: str) -> None:
    problem = path_problem(name)
    assert problem is not None and words in problem, problem


@pytest.mark.parametrize("template", ["f{index}.png", "f{index:02d}.png", "{index:9}", "{index:09d}", "{index:d}",
                                      "{{literal}}{index}"])
def test_small_templates_pass(template: str) -> None:
    assert template_problem(template, {"index"}) is None


@pytest.mark.parametrize("template, words", [
    ("{index:>1000000000}.png", "width up to 9"), ("{index:099999999999}", "width up to 9"),
    ("{index:010d}", "width up to 9"), ("{index:x}", "width up to 9"), ("{index!r}", "not allowed"),
    ("{index.real}", "unknown field"), ("{index[0]}", "unknown field"), ("{}", "unknown field"),
    ("{run}", "unknown field"), ("{index", "bad template"), ("{index:{index}}", "width up to 9"),
])
def test_other_templates_are_refused(template: str, words: str) -> None:
    problem = template_problem(template, {"index"})
    assert problem is not None and words in problem, problem


def test_clashes_name_both_outputs() -> None:
    assert clashes([("a.txt", 0), ("b/a.txt", 1)]) is None
    assert clashes([("a", 0), ("a/b.json", 1)])[:4] == ("a/b.json", 1, "a", 0)
    assert clashes([("f0/x.png", 0), ("f0", 1)])[:4] == ("f0", 1, "f0/x.png", 0)
    assert clashes([("x.png", 0), ("X.PNG", 2)])[:4] == ("X.PNG", 2, "x.png", 0)
    assert clashes([("m.json", 1), ("m.json", 3)])[:4] == ("m.json", 3, "m.json", 1)
