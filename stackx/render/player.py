"""Self-contained HTML pages that play lists of pictures; they need no network and no script beyond their own.

Two pages:

- ``player_html``: the lab's page, one ``<img>`` and ``setInterval`` looping over the pictures. The lab's
  ``index.html`` is this page, byte for byte.
- ``controlled_player_html``: one or more panels shown side by side and always on the same frame (the same
  scene under several solvers, or one run), with pause, step back and forward, a frame slider and a speed
  control; the keys space (play/pause), left and right arrows (step), Home and End (first, last frame),
  ``+`` and ``-`` (speed); and under the controls the step and time of the frame shown. Every picture is
  loaded once when the page opens, so the panels change together.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass

SPEEDS = (0.25, 0.5, 1, 2, 4)  # playback speeds offered, times the configured interval per frame


def _head(title: str) -> str:
    """The start of a page, up to its title: no favicon request (it would fail when served from a folder)."""
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<link rel="icon" href="data:,">
<title>{html.escape(title)}</title>
"""


def player_html(images: list[str], interval_ms: int, title: str) -> str:
    """The lab's page; it needs no network and no script beyond its own few lines."""
    first = html.escape(images[0], quote=True)
    return f"""{_head(title)}<style>body {{ background: #14141c; color: #ddd; font-family: sans-serif; text-align: center; }}
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


@dataclass
class Panel:
    """One column of pictures in a player: its heading, a line under it (e.g. the solver's settings), one
    picture per frame and, optionally, a line of figures per frame shown beneath the picture."""

    caption: str
    detail: str
    images: list[str]
    notes: list[str] | None = None


SCRIPT = """
const data = JSON.parse(document.getElementById("data").textContent);
const count = data.labels.length;
const speeds = data.speeds;
const pictures = Array.from(document.querySelectorAll("img.frame"));
const notes = Array.from(document.querySelectorAll("p.note"));
const slider = document.getElementById("slider");
const play = document.getElementById("play");
const speed = document.getElementById("speed");
let shown = 0;
let playing = true;
let timer = null;

for (const panel of data.panels) {
  for (const src of panel.images) { new Image().src = src; }
}

function show(index) {
  shown = ((index % count) + count) % count;
  data.panels.forEach((panel, p) => {
    pictures[p].src = panel.images[shown];
    pictures[p].alt = `${panel.caption}: frame ${shown + 1} of ${count}`;
    if (panel.notes) notes[p].textContent = panel.notes[shown];
  });
  slider.value = String(shown);
  document.getElementById("label").textContent = `frame ${shown + 1} / ${count} · ${data.labels[shown]}`;
}

function schedule() {
  if (timer !== null) clearInterval(timer);
  timer = playing ? setInterval(() => show(shown + 1), data.interval / Number(speed.value)) : null;
  play.textContent = playing ? "pause" : "play";
  play.setAttribute("aria-pressed", String(!playing));
}

function setPlaying(on) { playing = on; schedule(); }
function step(by) { setPlaying(false); show(shown + by); }
function faster(by) {
  const at = Math.min(speeds.length - 1, Math.max(0, speeds.indexOf(Number(speed.value)) + by));
  speed.value = String(speeds[at]);
  schedule();
}

play.addEventListener("click", () => setPlaying(!playing));
document.getElementById("back").addEventListener("click", () => step(-1));
document.getElementById("forward").addEventListener("click", () => step(1));
slider.addEventListener("input", () => { setPlaying(false); show(Number(slider.value)); });
speed.addEventListener("change", schedule);
document.addEventListener("keydown", (event) => {
  if (event.altKey || event.ctrlKey || event.metaKey || event.target === speed) return;
  const onSlider = event.target === slider;
  if (event.key === " ") { event.preventDefault(); setPlaying(!playing); }
  else if (event.key === "ArrowRight" && !onSlider) { event.preventDefault(); step(1); }
  else if (event.key === "ArrowLeft" && !onSlider) { event.preventDefault(); step(-1); }
  else if (event.key === "Home" && !onSlider) { event.preventDefault(); setPlaying(false); show(0); }
  else if (event.key === "End" && !onSlider) { event.preventDefault(); setPlaying(false); show(count - 1); }
  else if (event.key === "+" || event.key === "=") { faster(1); }
  else if (event.key === "-") { faster(-1); }
});
show(0);
schedule();
"""

STYLE = """
body { background: #14141c; color: #ddd; font-family: sans-serif; text-align: center; margin: 1em; }
#panels { display: flex; flex-wrap: wrap; justify-content: center; align-items: flex-end; gap: 1em; }
figure { margin: 0; }
figure { width: %(width)s; }
figcaption { font-weight: bold; } figcaption span { display: block; font-weight: normal; color: #aaa;
  font-size: 0.85em; overflow-wrap: anywhere; }
img.frame { image-rendering: pixelated; width: 100%%; height: auto; aspect-ratio: %(aspect)s; display: block; }
p.note { margin: 0.3em 0 0; font-size: 0.9em; color: #bbb; font-variant-numeric: tabular-nums; }
#controls { margin: 1em auto 0.3em; display: flex; gap: 0.6em; justify-content: center; align-items: center; }
#controls button { min-width: 5.5em; } #slider { width: min(50vw, 520px); }
#label { font-variant-numeric: tabular-nums; } .keys { color: #888; font-size: 0.85em; }
"""


def controlled_player_html(title: str, panels: list[Panel], labels: list[str], interval_ms: int,
                           size: tuple[int, int]) -> str:
    """A page playing ``panels`` in step, one frame per entry of ``labels`` (its step and time). The pictures
    are ``size`` (width, height) pixels; each is shown twice as big, pixelated, or smaller when the panels
    would not fit side by side in the window."""
    count = len(labels)
    if any(len(p.images) != count or (p.notes is not None and len(p.notes) != count) for p in panels):
        raise ValueError("every panel needs one picture (and one note, if any) per frame")
    data = {"labels": labels, "interval": interval_ms, "speeds": list(SPEEDS),
            "panels": [{"caption": p.caption, "images": p.images, "notes": p.notes} for p in panels]}
    payload = json.dumps(data).replace("</", "<\\/")  # no '</script>' can end the block early
    figures = "\n".join(
        f'<figure><figcaption>{html.escape(p.caption)}<span>{html.escape(p.detail)}</span></figcaption>'
        f'<img class="frame" src="{html.escape(p.images[0], quote=True)}" alt="{html.escape(p.caption)}: frame 1 '
        f'of {count}"><p class="note">{html.escape(p.notes[0]) if p.notes else ""}</p></figure>' for p in panels)
    options = "".join(f'<option value="{s:g}"{" selected" if s == 1 else ""}>{s:g}x</option>' for s in SPEEDS)
    n = len(panels)
    style = STYLE % {"width": f"min({2 * size[0]}px, calc((100vw - {2 + n - 1}em) / {n}))",
                     "aspect": f"{size[0]} / {size[1]}"}
    return f"""{_head(title)}<style>{style}</style>
</head>
<body>
<h1>{html.escape(title)}</h1>
<div id="panels">
{figures}
</div>
<div id="controls">
<button id="back" type="button" title="previous frame (left arrow)">&#9664; step</button>
<button id="play" type="button" title="play or pause (space)" aria-pressed="false">pause</button>
<button id="forward" type="button" title="next frame (right arrow)">step &#9654;</button>
<input id="slider" type="range" min="0" max="{count - 1}" step="1" value="0" aria-label="frame">
<label>speed <select id="speed" title="speed (+ and -)">{options}</select></label>
</div>
<p id="label">frame 1 / {count} · {html.escape(labels[0])}</p>
<p class="keys">space: play / pause · &larr; &rarr;: step · Home / End: first / last frame · + / -: speed</p>
<script type="application/json" id="data">{payload}</script>
<script>{SCRIPT}</script>
</body>
</html>
"""
