"""``python -m benchmarks.perf_map``: where a planar solver's compiled step spends its time, kernel by kernel,
from Linux ``perf``.

numba's machine code lives in memory that no file names, so ``perf report`` shows its samples as bare
addresses. ``perf`` reads the names of such code from ``/tmp/perf-PID.map`` (one line per function: start,
size, name, in hex), which this module writes from numba's own records: every function of every compiled
library in the process, its start from the JIT's symbol table, its size up to the next function's start. Only
code compiled in this process has those records (code loaded from numba's cache has no module to list), so the
run compiles afresh into a cache folder of its own (``STACKX_CACHE_DIR``, set before stackx is imported).

The workload: ``--subject`` (a name of ``benchmarks.planar.STACKX``) stepping ``--rows`` copies of a pyramid of
``--pyramid`` rows, as ``benchmarks.planar`` steps it, on ``--threads`` threads; once compiled, the map is
written and ``perf record`` samples this process for ``--seconds`` while it steps. Printed: the share of the
samples of each function (kernels by their module path, inlined ones counted in their callers), the largest
``--top``. Needs ``perf`` on the PATH and leave to sample (``kernel.perf_event_paranoid`` at most 1, or root).
"""

from __future__ import annotations

import argparse
import gc
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MANGLED = re.compile(r"(\d+)")


def readable(symbol: str) -> str:
    """A numba function's mangled symbol (``_ZN6stackx6models6planar6banded6factorB3v48...``) as its dotted
    path (``stackx.solvers.planar.banded.factor``); other symbols as they are."""
    if not symbol.startswith("_ZN"):
        return symbol
    parts, at = [], 3
    while at < len(symbol) and symbol[at].isdigit():
        length = MANGLED.match(symbol, at)
        assert length is not None
        at = length.end()
        parts.append(symbol[at:at + int(length.group(1))])
        at += int(length.group(1))
    return ".".join(parts) or symbol


def write_map() -> tuple[Path, int]:
    """``/tmp/perf-PID.map`` for this process's compiled numba functions; returns its path and how many."""
    from numba.core.registry import CPUDispatcher

    starts: dict[int, str] = {}
    seen: set[int] = set()
    # by type, not isinstance: a weak proxy among the objects whose referent is gone raises on isinstance
    for dispatcher in [o for o in gc.get_objects() if issubclass(type(o), CPUDispatcher)]:
        for result in dispatcher.overloads.values():
            library = result.library
            if id(library) in seen:
                continue
            seen.add(id(library))
            try:
                names = [f.name for f in library._final_module.functions if not f.is_declaration]
            except Exception:  # loaded from a cache: nothing to list
                continue
            for name in names:
                try:
                    address = library.get_pointer_to_function(name)
                except Exception:
                    continue
                if address:
                    starts[address] = readable(name)
    ordered = sorted(starts.items())
    path = Path(f"/tmp/perf-{os.getpid()}.map")
    with path.open("w") as out:
        for (address, name), (after, _) in zip(ordered, ordered[1:] + [(ordered[-1][0] + 4096, "")]):
            out.write(f"{address:x} {min(after - address, 1 << 20):x} {name}\n")
    return path, len(ordered)


def shares(data: Path, top: int) -> list[tuple[float, str]]:
    """The ``top`` functions of a ``perf.data`` by their share of the samples (%)."""
    report = subprocess.run(["perf", "report", "-i", str(data), "--no-children", "--sort", "sym", "--stdio",
                             "-g", "none"], capture_output=True, text=True, check=True).stdout
    found = []
    for line in report.splitlines():
        match = re.match(r"\s*([\d.]+)%\s+\[[.k]\]\s+(\S+)", line)
        if match:
            found.append((float(match.group(1)), readable(match.group(2))))
    return found[:top]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--subject", default="soft-step 4", help="a name of benchmarks.planar.STACKX")
    parser.add_argument("--pyramid", type=int, default=20, help="rows of the pyramid")
    parser.add_argument("--rows", type=int, default=64, help="copies of the pile stepped in one batch")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--top", type=int, default=25)
    args = parser.parse_args()
    if shutil.which("perf") is None:
        sys.exit("perf is not on the PATH")
    folder = Path(tempfile.mkdtemp(prefix="stackx-perf-"))
    os.environ["STACKX_CACHE_DIR"] = str(folder / "cache")  # compiled afresh: see the module text

    from benchmarks.planar import STACKX, Stackx, pyramid

    solver, knobs = STACKX[args.subject]
    subject = Stackx(solver, knobs, pyramid(args.pyramid), args.rows, args.threads)
    print(f"compiling {args.subject} ...", flush=True)
    subject.prepare(1)()
    path, functions = write_map()
    print(f"{functions} compiled functions named in {path}", flush=True)
    data = folder / "perf.data"
    record = subprocess.Popen(["perf", "record", "-F", "999", "-p", str(os.getpid()), "-o", str(data), "--",
                               "sleep", str(args.seconds)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    steps = 0
    time.sleep(0.5)  # perf attaches
    began = time.perf_counter()
    while record.poll() is None:
        subject.prepare(5)()
        steps += 5
    elapsed = time.perf_counter() - began
    if record.returncode != 0:
        sys.exit(f"perf record failed: {record.stderr.read().decode()[-500:] if record.stderr else ''}")
    print(f"{args.subject}, {args.rows} rows of pyramid-{args.pyramid}, {args.threads} thread(s): "
          f"{elapsed / (steps * args.rows) * 1e6:.1f} µs per world-step while sampled")
    for share, name in shares(data, args.top):
        print(f"{share:6.2f}%  {name}")
    path.unlink(missing_ok=True)
    shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
