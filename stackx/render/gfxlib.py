"""The lab's drawing toolbox: an RGB canvas with lines, filled rectangles and filled convex polygons (a
rotated box), saved as PNG.

Pixels live in one ``bytearray`` (row-major, 3 bytes each), so drawing needs nothing but the standard
library and the PNG bytes depend only on the pixels: the same drawing always gives the same file.
"""

from __future__ import annotations

import math
import struct
import zlib

RGB = tuple[int, int, int]


class Canvas:
    """A ``w`` x ``h`` picture filled with ``bg``; (0, 0) is the top-left pixel."""

    def __init__(self, w: int, h: int, bg: RGB = (0, 0, 0)) -> None:
        if w <= 0 or h <= 0:
            raise ValueError(f"canvas size must be positive, got {w}x{h}")
        self.w, self.h = w, h
        self.pixels = bytearray(bytes(_rgb(bg)) * (w * h))

    def get(self, x: int, y: int) -> RGB:
        i = 3 * (y * self.w + x)
        return self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]

    def set(self, x: int, y: int, rgb: RGB) -> None:
        """Colour one pixel; points outside the canvas are ignored."""
        if 0 <= x < self.w and 0 <= y < self.h:
            i = 3 * (y * self.w + x)
            self.pixels[i:i + 3] = bytes(_rgb(rgb))

    def line(self, x0: int, y0: int, x1: int, y1: int, rgb: RGB) -> None:
        """A one-pixel line including both end points (Bresenham), clipped to the canvas.

        Only the part of the line over the canvas is walked, so a line to a point a billion pixels away costs
        what its visible part does. The pixels are exactly those of the whole walk from ``(x0, y0)``: step n
        of the walk is found in closed form (``_walk_state``), so the walk can start at the first step on the
        canvas and stop after the last one."""
        steps = _visible_steps(x0, y0, x1, y1, self.w, self.h)
        if steps is None:
            return
        first, last = steps
        x, y, err = _walk_state(x0, y0, x1, y1, first)
        dx, dy = abs(x1 - x0), -abs(y1 - y0)
        sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
        for _ in range(last - first + 1):
            self.set(x, y, rgb)
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x += sx
            if e2 <= dx:
                err += dx
                y += sy

    def fill_rect(self, x0: int, y0: int, x1: int, y1: int, rgb: RGB) -> None:
        """A filled rectangle with both corners included, clipped to the canvas."""
        x0, x1 = sorted((x0, x1))
        y0, y1 = sorted((y0, y1))
        x0, x1 = max(x0, 0), min(x1, self.w - 1)
        y0, y1 = max(y0, 0), min(y1, self.h - 1)
        if x0 > x1 or y0 > y1:
            return
        run = bytes(_rgb(rgb)) * (x1 - x0 + 1)
        for y in range(y0, y1 + 1):
            i = 3 * (y * self.w + x0)
            self.pixels[i:i + len(run)] = run

    def fill_convex(self, points: list[tuple[float, float]], rgb: RGB) -> None:
        """A filled convex polygon with corners at real-valued screen ``points`` (in order around it), clipped
        to the canvas. Pixel (x, y) is filled when its centre (x + 0.5, y + 0.5) lies inside or on the edge,
        the usual rule for shapes that do not sit on the pixel grid: a rotated box covers the same pixels
        whichever corner it is given from, and two boxes that share an edge leave no gap between them."""
        if len(points) < 3:
            return
        ys = [p[1] for p in points]
        top = max(math.ceil(min(ys) - 0.5), 0)
        bottom = min(math.floor(max(ys) - 0.5), self.h - 1)
        edges = list(zip(points, points[1:] + points[:1]))
        for y in range(top, bottom + 1):
            c = y + 0.5
            left, right = math.inf, -math.inf
            for (ax, ay), (bx, by) in edges:
                if ay == by:
                    if ay == c:
                        left, right = min(left, ax, bx), max(right, ax, bx)
                elif min(ay, by) <= c <= max(ay, by):
                    x = ax + (c - ay) * (bx - ax) / (by - ay)
                    left, right = min(left, x), max(right, x)
            if left > right:
                continue
            x0 = max(math.ceil(left - 0.5), 0)
            x1 = min(math.floor(right - 0.5), self.w - 1)
            if x0 > x1:
                continue
            run = bytes(_rgb(rgb)) * (x1 - x0 + 1)
            i = 3 * (y * self.w + x0)
            self.pixels[i:i + len(run)] = run

    def png_bytes(self) -> bytes:
        """The picture as an 8-bit RGB PNG (no filtering, fixed compression: deterministic bytes)."""
        stride = 3 * self.w
        raw = b"".join(b"\x00" + self.pixels[y * stride:(y + 1) * stride] for y in range(self.h))

        def chunk(kind: bytes, body: bytes) -> bytes:
            return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

        header = struct.pack(">IIBBBBB", self.w, self.h, 8, 2, 0, 0, 0)
        return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9))
                + chunk(b"IEND", b""))

    def write_png(self, path: str) -> None:
        """Save as PNG at ``path`` (atomically: a reader never sees half a file)."""
        from pathlib import Path

        from stackx.output.outdir import atomic_write

        atomic_write(Path(path), self.png_bytes())


def _walk_state(x0: int, y0: int, x1: int, y1: int, n: int) -> tuple[int, int, int]:
    """Where the Bresenham walk from ``(x0, y0)`` to ``(x1, y1)`` is at its step ``n`` (0 is the first end
    point): the pixel and the walk's error term, as ``Canvas.line``'s loop would have them after n turns.

    The walk moves the longer axis (major, length ``big``) one pixel every step and the other (minor, length
    ``small``) whenever its error term says so; after n steps the minor axis has moved
    ``floor((2 n small + big) / (2 big))`` pixels (n x small / big rounded, halves away from the start), and the
    error term, which each x move lowers by ``|dy|`` and each y move raises by ``dx``, is
    ``(y moves + 1) dx - (x moves + 1) |dy|``. Exact in integers, however far the end points."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
    big, small = max(dx, dy), min(dx, dy)
    minor = (2 * n * small + big) // (2 * big) if big else 0
    kx, ky = (n, minor) if dx >= dy else (minor, n)
    return x0 + sx * kx, y0 + sy * ky, (ky + 1) * dx - (kx + 1) * dy


def _visible_steps(x0: int, y0: int, x1: int, y1: int, w: int, h: int) -> tuple[int, int] | None:
    """The first and last step of the walk from ``(x0, y0)`` to ``(x1, y1)`` whose pixel is on a ``w`` x ``h``
    canvas (None when none is). Each axis's position only moves one way along the walk, so the steps on the
    canvas are one range: the steps where the major axis is inside, narrowed to those where the minor is."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    big, small = max(dx, dy), min(dx, dy)
    (a0, sa, wa), (b0, sb, wb) = ((x0, x1, w), (y0, y1, h)) if dx >= dy else ((y0, y1, h), (x0, x1, w))
    first, last = _inside(a0, 1 if a0 < sa else -1, wa)  # major axis: position a0 +- n
    first, last = max(first, 0), min(last, big)
    lo, hi = _inside(b0, 1 if b0 < sb else -1, wb)  # minor axis: moved m(n) = floor((2n small + big) / 2big)
    if small == 0:
        if lo > 0 or hi < 0:
            return None
    else:
        first = max(first, -((-(2 * lo - 1) * big) // (2 * small)))  # least n with m(n) >= lo
        last = min(last, -((-(2 * hi + 1) * big) // (2 * small)) - 1)  # greatest n with m(n) <= hi
    return (first, last) if first <= last else None


def _inside(start: int, step: int, size: int) -> tuple[int, int]:
    """The range of moves k (possibly empty, possibly negative) with ``start + step * k`` in ``0..size-1``."""
    if step > 0:
        return -start, size - 1 - start
    return start - (size - 1), start


def _rgb(rgb: RGB) -> RGB:
    if len(rgb) != 3 or not all(isinstance(c, int) and 0 <= c <= 255 for c in rgb):
        raise ValueError(f"a colour is three whole numbers 0..255, got {rgb!r}")
    return rgb
