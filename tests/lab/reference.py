"""A plain-Python transcription of the lab's rules: the yardstick for stackx's lab artifacts.

It is written from the lab text and its contract alone, with the standard library only, so that an
error in stackx would have to be made a second time, independently, to go unnoticed.
"""

from __future__ import annotations

import functools
import struct
import zlib
from typing import Iterator, NamedTuple

G = -9.8
DT = 1 / 60
SLOP = 0.01
PERCENT = 0.2
HALF = 0.5
FLOOR_INV_MASS = 0.0
BOX_INV_MASS = 1.0

STACK_START = [2.5 + 1.6 * i for i in range(5)]
STACK_STEPS = 900
STACK_ITERATIONS = 15
FRAME_EVERY = 15
FRAME_COUNT = 12

RGB = tuple[int, int, int]
Picture = list[list[RGB]]

SIZE = 256
SCALE = 25.6
BOX_HALF_WIDTH = 1.5
BACKGROUND: RGB = (20, 20, 28)
BOX_COLOURS: list[RGB] = [(230, 120, 110), (230, 190, 110), (150, 220, 120), (120, 190, 230), (190, 140, 230)]
WHITE: RGB = (255, 255, 255)
BLACK: RGB = (0, 0, 0)
RED: RGB = (255, 0, 0)


class Run(NamedTuple):
    """Final heights of a run and the heights captured along the way (empty unless asked for)."""

    final: list[float]
    captured: list[list[float]]


def correction_shares(
    depth: float, slop: float, percent: float, inv1: float, inv2: float
) -> tuple[float, float]:
    """The lab's correct(): how far object 1 moves along -n and object 2 along +n."""
    total = inv1 + inv2
    if total == 0:
        return 0.0, 0.0
    c = max(depth - slop, 0.0) / total * percent
    return c * inv1, c * inv2


def contact_depths(ys: list[float], half: float = HALF) -> list[float]:
    """Depths of the floor contact and of each pair bottom-up; positive means overlap."""
    floor = [half - ys[0]]
    pairs = [(half + half) - (ys[i + 1] - ys[i]) for i in range(len(ys) - 1)]
    return floor + pairs


def max_depth(ys: list[float], half: float = HALF) -> float:
    """Largest overlap over all contacts, 0 when nothing overlaps."""
    return max(0.0, *contact_depths(ys, half))


def simulate(
    ys: list[float],
    steps: int,
    iterations: int,
    correction: bool,
    slop: float = SLOP,
    percent: float = PERCENT,
    g: float = G,
    dt: float = DT,
    half: float = HALF,
    capture_every: int | None = None,
) -> Run:
    """Run the lab's column from rest, one step being gravity, velocity passes, positions, correction."""
    y = [float(v) for v in ys]
    v = [0.0] * len(y)
    inv = [BOX_INV_MASS] * len(y)
    captured: list[list[float]] = []
    for step in range(steps):
        if capture_every is not None and step % capture_every == 0:
            captured.append(list(y))

        for i in range(len(v)):
            v[i] += g * dt

        for _ in range(iterations):
            if half - y[0] > 0 and v[0] < 0:
                v[0] = 0.0
            for i in range(len(y) - 1):
                depth = (half + half) - (y[i + 1] - y[i])
                rv = v[i + 1] - v[i]
                if depth > 0 and rv < 0:
                    j = -rv / (inv[i] + inv[i + 1])
                    v[i] -= j * inv[i]
                    v[i + 1] += j * inv[i + 1]

        for i in range(len(y)):
            y[i] += v[i] * dt

        if correction:
            _, up = correction_shares(half - y[0], slop, percent, FLOOR_INV_MASS, inv[0])
            y[0] += up
            for i in range(len(y) - 1):
                depth = (half + half) - (y[i + 1] - y[i])
                down, up = correction_shares(depth, slop, percent, inv[i], inv[i + 1])
                y[i] -= down
                y[i + 1] += up
    return Run(y, captured)


@functools.cache
def _sink_depth(correction: bool) -> float:
    """Final floor depth of the single dropped box, clipped at 0."""
    final = simulate([1.5], 600, 10, correction).final
    return max(0.0, HALF - final[0])


def expected_sink() -> dict[str, float]:
    """03-sink.txt: the depth a box settles at when only its velocity is fixed."""
    return {"depth_final": _sink_depth(False)}


def expected_fixed() -> dict[str, float]:
    """04-fixed.txt: the same drop with position correction, and how much it gained."""
    d03, d04 = _sink_depth(False), _sink_depth(True)
    return {"depth_final": d04, "improved": d03 - d04}


def expected_iters() -> dict[str, float]:
    """05-iters.txt: final largest depth of a three-box column for 1, 4 and 10 iterations."""
    start = [1.5 + i for i in range(3)]
    return {f"iters{n}": max_depth(simulate(start, 600, n, True).final) for n in (1, 4, 10)}


@functools.cache
def _stack_run() -> Run:
    """The five-box run is the slowest; text, picture and frame tests all share this one result."""
    return simulate(STACK_START, STACK_STEPS, STACK_ITERATIONS, True, capture_every=FRAME_EVERY)


def stack_run() -> Run:
    """The five-box run behind 06-stack.txt, stack.png and the frames (computed once)."""
    run = _stack_run()
    return Run(list(run.final), [list(s) for s in run.captured])


def expected_stack() -> dict[str, float]:
    """06-stack.txt: final heights bottom-up and the largest final depth."""
    final = stack_run().final
    values = {f"y{i + 1}": y for i, y in enumerate(final)}
    values["max_depth"] = max_depth(final)
    return values


def expected_texts() -> dict[str, dict[str, float]]:
    """Every text artifact's expected key=value content, keys in file order."""
    return {
        "03-sink.txt": expected_sink(),
        "04-fixed.txt": expected_fixed(),
        "05-iters.txt": expected_iters(),
        "06-stack.txt": expected_stack(),
    }


def frame_states() -> list[list[float]]:
    """Heights before steps 0, 15, ..., 165 of the five-box run, in frame order."""
    return stack_run().captured[:FRAME_COUNT]


def blank(width: int, height: int, colour: RGB) -> Picture:
    """A picture of one colour, rows top to bottom; each row its own list so pixels can be set."""
    return [[colour] * width for _ in range(height)]


def draw_check() -> Picture:
    """00-check.png: black 64x64, white diagonal, then the red row 32 over it."""
    picture = blank(64, 64, BLACK)
    for i in range(64):
        picture[i][i] = WHITE
    picture[32] = [RED] * 64
    return picture


def draw_stack(ys: list[float]) -> Picture:
    """The stack picture of a state: boxes bottom-up, clipped to the canvas, floor row last."""
    picture = blank(SIZE, SIZE, BACKGROUND)
    left = int(-BOX_HALF_WIDTH * SCALE + 128)
    right = int(BOX_HALF_WIDTH * SCALE + 128)
    for y, colour in zip(ys, BOX_COLOURS, strict=True):
        top = int(255 - (y + HALF) * SCALE)
        bottom = int(255 - (y - HALF) * SCALE)
        for row in range(max(top, 0), min(bottom, SIZE - 1) + 1):
            for x in range(max(left, 0), min(right, SIZE - 1) + 1):
                picture[row][x] = colour
    picture[SIZE - 1] = [WHITE] * SIZE
    return picture


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class PngHeader(NamedTuple):
    width: int
    height: int
    bit_depth: int
    colour_type: int
    interlace: int


def _chunks(data: bytes) -> Iterator[tuple[bytes, bytes]]:
    """Chunk types and bodies in file order, refusing a bad signature or CRC."""
    if data[:8] != PNG_SIGNATURE:
        raise ValueError("not a PNG signature")
    pos = 8
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        if zlib.crc32(kind + body) != crc:
            raise ValueError(f"bad CRC in chunk {kind!r}")
        yield kind, body
        pos += 12 + length


def png_header(data: bytes) -> PngHeader:
    """The IHDR fields, which must come first."""
    kind, body = next(_chunks(data))
    if kind != b"IHDR":
        raise ValueError("first chunk is not IHDR")
    width, height, bit_depth, colour_type, _, _, interlace = struct.unpack(">IIBBBBB", body)
    return PngHeader(width, height, bit_depth, colour_type, interlace)


def _paeth(a: int, b: int, c: int) -> int:
    """The PNG Paeth predictor, ties broken in the order a, b, c as the PNG spec requires."""
    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def _unfilter(kind: int, line: bytes, prev: bytearray, bpp: int) -> bytearray:
    """Undo one scanline's filter (PNG filter types 0-4)."""
    out = bytearray(line)
    for i in range(len(out)):
        a = out[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        if kind == 0:
            predictor = 0
        elif kind == 1:
            predictor = a
        elif kind == 2:
            predictor = b
        elif kind == 3:
            predictor = (a + b) // 2
        elif kind == 4:
            predictor = _paeth(a, b, c)
        else:
            raise ValueError(f"unknown filter type {kind}")
        out[i] = (out[i] + predictor) & 0xFF
    return out


def read_png(data: bytes) -> tuple[int, int, Picture]:
    """Decode an 8-bit, non-interlaced RGB or RGBA PNG to rows of RGB tuples (alpha dropped)."""
    header = png_header(data)
    if header.bit_depth != 8 or header.interlace != 0 or header.colour_type not in (2, 6):
        raise ValueError(f"unsupported PNG {header}")
    bpp = 3 if header.colour_type == 2 else 4
    raw = zlib.decompress(b"".join(body for kind, body in _chunks(data) if kind == b"IDAT"))
    stride = header.width * bpp
    if len(raw) != header.height * (stride + 1):
        raise ValueError("image data has the wrong length")
    rows: Picture = []
    prev = bytearray(stride)
    for r in range(header.height):
        start = r * (stride + 1)
        line = _unfilter(raw[start], raw[start + 1 : start + 1 + stride], prev, bpp)
        rows.append([(line[x], line[x + 1], line[x + 2]) for x in range(0, stride, bpp)])
        prev = line
    return header.width, header.height, rows
