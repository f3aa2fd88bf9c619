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
        """A one-pixel line including both end points (Bresenham), clipped to the canvas."""
        dx, dy = abs(x1 - x0), -abs(y1 - y0)
        sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
        err = dx + dy
        while True:
            self.set(x0, y0, rgb)
            if x0 == x1 and y0 == y1:
                return
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x0 += sx
            if e2 <= dx:
                err += dx
                y0 += sy

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


def _rgb(rgb: RGB) -> RGB:
    if len(rgb) != 3 or not all(isinstance(c, int) and 0 <= c <= 255 for c in rgb):
        raise ValueError(f"a colour is three whole numbers 0..255, got {rgb!r}")
    return rgb
