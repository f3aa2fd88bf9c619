"""Time limits on what tests wait for: guards against a hang, never a measure of speed.

A limit on a subprocess or a server only has to end a test that would otherwise wait forever (a command stuck
on a lock, a server that never answers). How long the work takes depends on the machine and on what else runs on
it (two shared cores under a full suite run several times slower than alone), so a limit sized to the work would
make a test's outcome depend on load. Every such limit is written as the time the wait takes on an idle machine
with room to spare, and passed through ``hang_limit``, which multiplies it by ``STACKX_TEST_TIME_SCALE``
(default 10). ``STACKX_TEST_TIME_SCALE=0`` removes the limits altogether (a debugger, a very slow emulator).
Work that cannot hang but only take long (a bench of every hard case) has no limit at all.
"""

from __future__ import annotations

import os

SCALE_ENV = "STACKX_TEST_TIME_SCALE"
DEFAULT_SCALE = 10.0  # an idle run's time x 10: a loaded 2-core machine measured 3x slower than idle


def time_scale() -> float:
    """The factor every limit is multiplied by (``STACKX_TEST_TIME_SCALE``, default 10; 0: no limits). A value
    that is not a number >= 0 is an error naming the variable, not a silent default."""
    text = os.environ.get(SCALE_ENV, "").strip()
    if not text:
        return DEFAULT_SCALE
    try:
        scale = float(text)
    except ValueError:
        scale = -1.0
    if not scale >= 0 or scale == float("inf"):
        raise ValueError(f"{SCALE_ENV}={text!r}: a number >= 0 (0: no time limits)")
    return scale


def hang_limit(seconds: float) -> float | None:
    """``seconds`` (the wait on an idle machine, with room) scaled by ``time_scale``; None (wait as long as it
    takes) when the scale is 0. Pass it as ``timeout=`` to ``subprocess.run``, ``wait`` or ``communicate``."""
    scale = time_scale()
    return None if scale == 0 else seconds * scale
