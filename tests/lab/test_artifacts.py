"""Every lab artifact stackx writes, against the independent transcription in reference.py."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from . import reference as ref

TOLERANCE = 1e-9

KEY_ORDER = {
    "03-sink.txt": ["depth_final"],
    "04-fixed.txt": ["depth_final", "improved"],
    "05-iters.txt": ["iters1", "iters4", "iters10"],
    "06-stack.txt": ["y1", "y2", "y3", "y4", "y5", "max_depth"],
}
FRAME_NAMES = [f"f{i:02d}.png" for i in range(ref.FRAME_COUNT)]
STACK_PICTURES = ["stack.png", *FRAME_NAMES]
ARTIFACTS = ["00-check.png", *KEY_ORDER, *STACK_PICTURES, "index.html"]
WALL_CLOCK_FILES = {"timing.json"}


def read_pairs(path: Path) -> list[tuple[str, str]]:
    """A text artifact as (key, value string) pairs in file order; every line must be key=value."""
    pairs = []
    for line in path.read_text().splitlines():
        key, sep, value = line.partition("=")
        assert sep, f"{path.name}: line {line!r} is not key=value"
        pairs.append((key.strip(), value.strip()))
    return pairs


def picture_diff(a: ref.Picture, b: ref.Picture) -> list[tuple[int, int]]:
    """(x, y) of every pixel where two same-sized pictures differ."""
    return [
        (x, y) for y, (ra, rb) in enumerate(zip(a, b, strict=True)) for x in range(len(ra)) if ra[x] != rb[x]
    ]


def assert_picture(path: Path, want: ref.Picture) -> None:
    """Same size and every pixel equal, naming the first few differences when not."""
    width, height, got = ref.read_png(path.read_bytes())
    assert (width, height) == (len(want[0]), len(want))
    diff = picture_diff(got, want)
    shown = [f"({x},{y}) got {got[y][x]} want {want[y][x]}" for x, y in diff[:5]]
    assert not diff, f"{path.name}: {len(diff)} pixels differ, e.g. {shown}"


def stack_picture_states() -> dict[str, list[float]]:
    """The state each stack picture shows: the final one, then the captured frames."""
    return {"stack.png": ref.stack_run().final, **dict(zip(FRAME_NAMES, ref.frame_states(), strict=True))}


def test_all_artifacts_present(lab_out: Path) -> None:
    missing = [name for name in ARTIFACTS if not (lab_out / name).is_file()]
    assert not missing, f"missing artifacts: {missing}"


@pytest.mark.parametrize("name", list(KEY_ORDER))
def test_text_keys_in_contract_order(lab_out: Path, name: str) -> None:
    assert [key for key, _ in read_pairs(lab_out / name)] == KEY_ORDER[name]


@pytest.mark.parametrize("name", list(KEY_ORDER))
def test_text_values_are_finite_decimals(lab_out: Path, name: str) -> None:
    for key, value in read_pairs(lab_out / name):
        assert math.isfinite(float(value)), f"{name}: {key}={value!r}"


@pytest.mark.parametrize("name", list(KEY_ORDER))
def test_text_values_match_reference(lab_out: Path, name: str) -> None:
    want = ref.expected_texts()[name]
    got = dict(read_pairs(lab_out / name))
    wrong = {key: (got.get(key), repr(value)) for key, value in want.items()
             if key not in got or not abs(float(got[key]) - value) <= TOLERANCE}
    assert not wrong, f"{name}: (got, want) {wrong}"


@pytest.mark.parametrize("name", ["00-check.png", *STACK_PICTURES])
def test_png_is_8bit_rgb_of_the_right_size(lab_out: Path, name: str) -> None:
    header = ref.png_header((lab_out / name).read_bytes())
    size = 64 if name == "00-check.png" else ref.SIZE
    assert (header.width, header.height) == (size, size)
    assert (header.bit_depth, header.colour_type, header.interlace) == (8, 2, 0)


def test_check_png_is_the_test_pattern(lab_out: Path) -> None:
    assert_picture(lab_out / "00-check.png", ref.draw_check())


@pytest.mark.parametrize("name", STACK_PICTURES)
def test_stack_picture_matches_reference(lab_out: Path, name: str) -> None:
    assert_picture(lab_out / name, ref.draw_stack(stack_picture_states()[name]))


def test_index_html_plays_the_twelve_frames_in_order(lab_out: Path) -> None:
    html = (lab_out / "index.html").read_text()
    assert html.count("<img") == 1
    assert "setInterval" in html
    positions = [html.find(name) for name in FRAME_NAMES]
    assert -1 not in positions, f"missing: {[n for n, p in zip(FRAME_NAMES, positions) if p == -1]}"
    assert positions == sorted(positions), "frame names out of order"


def folder_bytes(folder: Path) -> dict[str, bytes]:
    """Every file under a folder by relative path, except those that hold wall-clock time by design."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name not in WALL_CLOCK_FILES}


def test_two_runs_are_byte_identical(lab_out: Path, lab_out_again: Path) -> None:
    first, second = folder_bytes(lab_out), folder_bytes(lab_out_again)
    assert sorted(first) == sorted(second), f"only in one run: {sorted(first.keys() ^ second.keys())}"
    differ = [name for name in first if first[name] != second[name]]
    assert not differ, f"differ between runs: {differ}"


def test_reference_sinks_without_correction() -> None:
    assert ref.expected_sink()["depth_final"] > 0.02


def test_reference_correction_returns_to_the_slop() -> None:
    d03 = ref.expected_sink()["depth_final"]
    fixed = ref.expected_fixed()
    assert abs(fixed["depth_final"] - ref.SLOP) < 0.005
    assert fixed["improved"] == d03 - fixed["depth_final"]
    assert fixed["improved"] > 0.5 * d03


def test_reference_depth_falls_with_iterations() -> None:
    iters = ref.expected_iters()
    assert iters["iters1"] > iters["iters4"] > iters["iters10"] > 0


def test_reference_stack_settles_where_the_lab_says() -> None:
    stack = ref.expected_stack()
    heights = [stack[f"y{i}"] for i in range(1, 6)]
    for got, near in zip(heights, [0.47, 1.44, 2.41, 3.38, 4.37], strict=True):
        assert abs(got - near) < 0.006
    assert 0 < stack["max_depth"] <= 0.05


def test_reference_frames_fall_then_settle() -> None:
    frames = [ref.draw_stack(state) for state in ref.frame_states()]
    pixels = ref.SIZE * ref.SIZE
    assert len(frames) == ref.FRAME_COUNT
    assert ref.frame_states()[0] == ref.STACK_START
    assert len(picture_diff(frames[10], frames[11])) < 0.01 * pixels
    assert len(picture_diff(frames[0], frames[11])) > 0.05 * pixels


def test_reference_check_pattern_is_as_described() -> None:
    picture = ref.draw_check()
    assert (len(picture[0]), len(picture)) == (64, 64)
    for y in range(64):
        for x in range(64):
            want = ref.RED if y == 32 else ref.WHITE if x == y else ref.BLACK
            assert picture[y][x] == want, (x, y)


def test_reference_keys_follow_the_contract() -> None:
    assert {name: list(values) for name, values in ref.expected_texts().items()} == KEY_ORDER
