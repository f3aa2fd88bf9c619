"""A self-contained HTML page that plays a list of pictures in order, one ``<img>`` and ``setInterval``."""

from __future__ import annotations

import html
import json


def player_html(images: list[str], interval_ms: int, title: str) -> str:
    """The page; it needs no network and no script beyond its own few lines."""
    first = html.escape(images[0], quote=True)
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<link rel="icon" href="data:,">
<title>{html.escape(title)}</title>
<style>body {{ background: #14141c; color: #ddd; font-family: sans-serif; text-align: center; }}
img {{ image-rendering: pixelated; width: 512px; height: 512px; }}</style>
</head>
<body>
<h1>{html.escape(title)}</h1>
<img id="frame" src="{first}" alt="frame 1 of {len(images)}">
<p id="caption">frame 1 / {len(images)}</p>
<script>
const frames = {json.dumps(images)};
let shown = 0;
setInterval(() => {{
  shown = (shown + 1) % frames.length;
  const img = document.getElementById("frame");
  img.src = frames[shown];
  img.alt = `frame ${{shown + 1}} of ${{frames.length}}`;
  document.getElementById("caption").textContent = `frame ${{shown + 1}} / ${{frames.length}}`;
}}, {interval_ms});
</script>
</body>
</html>
"""
