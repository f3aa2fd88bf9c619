"""``python -m benchmarks.robust_folder``: is an output folder all-or-nothing under SIGKILL and concurrent runs,
and does stackx keep its contract under every attack it has been seen to fail?

Kill trials: a folder holding an earlier complete run (OLD: ``--set gravity=-9.0``, plus a file of the user's,
``notes.txt``) is run over with ``stackx run configs/ --out X`` (NEW) and the run is killed with SIGKILL,
at a point chosen (seeded) one of two ways: on entering the k-th call of a system call that writes (under
``strace``'s fault injection, so the point is exact and does not depend on the machine's speed), or after a
random delay. Then X must hold exactly OLD or exactly NEW (every file, byte for byte; ``timing.json``
complete JSON), and the next run must finish and give NEW.

Concurrency trials: three runs of different configs into one folder at once; each must finish (a later one
waits for the earlier) and the manifest must list every experiment, with every file on disk as listed.

Attack trials (``benchmarks/attacks``): a file system mounted inside X, another program writing into X during
runs, planted lock and staging links, X's mode and setgid group, ``--out`` a mount point or in an unwritable
folder, 6 GB sparse files in a received folder, configs that explode (``compare`` over 10,000 runs, a line to
1e18, 20,000 named runs), plugins planted in an ancestor folder, a keyvalue key that is code, long error lines,
``serve`` under odd paths, idle connections and swapped links, SIGTERM and Ctrl-C, and ``bench`` and ``init``
killed at their switch. Each prints one line: name, PASS, FAIL or SKIP, and what it measured.

Prints the counts and a summary line; exits 1 when any trial fails. The suite runs a few trials of each
(``tests/robust/test_kill.py``, ``tests/robust/test_folder.py``, ``tests/robust/test_trials.py``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from benchmarks.attacks.kit import snapshot

REPO = Path(__file__).resolve().parents[1]
CONFIGS = REPO / "configs"
OLD = ("--set", "gravity=-9.0")
VOLATILE = "timing.json"
NOTES = "notes.txt"  # a file of the user's in the folder: every run must carry it over untouched
WRITES = ("openat", "write", "fsync", "mkdir", "unlinkat", "rmdir", "rename", "renameat2", "link", "linkat")
TOGETHER = ("03-sink", "06-stack", "04-fixed")  # the three configs run into one folder at once


def environ() -> dict[str, str]:
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path}


def command(out: Path, *extra: str, configs: Path | str = CONFIGS) -> list[str]:
    return [sys.executable, "-m", "stackx", "run", str(configs), "--out", str(out), "-q", *extra]


@dataclass
class References:
    old: dict[str, bytes]
    new: dict[str, bytes]
    seconds: float  # a clean NEW run over OLD
    points: list[tuple[str, int]]  # (system call, k): every write-type call of a clean NEW run over OLD


def references(root: Path) -> References:
    """The OLD and NEW folders' files, and the kill points a NEW run over OLD offers."""
    run = lambda *args: subprocess.run(list(args), check=True, cwd=REPO, env=environ(), timeout=600,  # noqa: E731
                                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    run(*command(root / "old", *OLD))
    (root / "old" / NOTES).write_text("the user's own file\n")
    old = snapshot(root / "old")
    shutil.copytree(root / "old", root / "new")
    start = time.perf_counter()
    run(*command(root / "new"))
    seconds = time.perf_counter() - start
    new = snapshot(root / "new")
    points: list[tuple[str, int]] = []
    if shutil.which("strace"):
        shutil.rmtree(root / "new")
        shutil.copytree(root / "old", root / "new")
        counts = root / "counts.txt"
        run("strace", "-c", "-o", str(counts), "-e", "trace=" + ",".join(WRITES), *command(root / "new"))
        for line in counts.read_text().splitlines():
            cells = line.split()
            if len(cells) >= 5 and cells[-1] in WRITES:  # % time, seconds, usecs/call, calls, [errors,] call
                calls = int(cells[3])
                points += [(cells[-1], k) for k in range(1, calls + 1)]
    return References(old, new, seconds, points)


def verdict(folder: Path, refs: References) -> str:
    """``old`` or ``new`` when ``folder`` holds exactly that run's files (timing aside); else what is wrong."""
    files = snapshot(folder)
    timing = files.pop(VOLATILE, None)
    try:
        if not isinstance(json.loads(timing or b""), dict):
            return "timing.json is not a JSON object"
    except ValueError:
        return "timing.json is missing or torn"
    for name, ref in (("old", refs.old), ("new", refs.new)):
        if files == {n: b for n, b in ref.items() if n != VOLATILE}:
            return name
    changed = sorted(n for n in set(files) | set(refs.new) if files.get(n) not in (refs.old.get(n), refs.new.get(n)))
    mixed = sorted(n for n in files if n in refs.old and files[n] == refs.new.get(n) != refs.old[n])
    return f"a mix: {len(mixed)} new file(s) among old ones; neither old nor new: {changed[:5]}"


def kill_trial(folder: Path, refs: References, point: tuple[str, int] | float) -> tuple[str, str, int]:
    """Copy OLD to ``folder``, run NEW into it, kill it at ``point`` ((call, k) or a delay in seconds);
    return (where, verdict, exit status)."""
    shutil.copytree(folder.parent / "old", folder)
    base = command(folder)
    if isinstance(point, tuple):
        call, k = point
        where = f"{call} #{k}"
        proc = subprocess.Popen(["strace", "-qq", "-o", "/dev/null", "-e", f"trace={call}",
                                 "-e", f"inject={call}:signal=KILL:when={k}", *base], cwd=REPO, env=environ(),
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        code = proc.wait(timeout=300)
    else:
        where = f"after {point:.3f} s"
        proc = subprocess.Popen(base, cwd=REPO, env=environ(), stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(point)
        proc.send_signal(signal.SIGKILL)
        code = proc.wait(timeout=60)
    return where, verdict(folder, refs), code


def after_kill(folder: Path, refs: References) -> str:
    """The next run into a killed run's folder: it must finish, give NEW and leave nothing beside it."""
    subprocess.run(command(folder), check=True, cwd=REPO, env=environ(), timeout=300,
                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    left = [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.")]
    return verdict(folder, refs) + (f"; left beside it: {left}" if left else "")


def kill_points(refs: References, trials: int, seed: int) -> list[tuple[str, int] | float]:
    """Half the trials on entering a system call that writes (when strace is here), the others after random
    delays; seeded."""
    rng = random.Random(seed)
    writes = [p for p in refs.points if p[0] != "openat"]  # the writing itself; opening files is mostly imports
    exact = min(len(writes), trials // 2)
    chosen: list[tuple[str, int] | float] = list(rng.sample(writes, exact))
    return chosen + [rng.uniform(0.0, refs.seconds * 1.1) for _ in range(trials - exact)]


def together_trial(folder: Path) -> str:
    """Three configs run into ``folder`` at once: '' when the manifest lists all three and every file is as
    listed, else what went wrong."""
    procs = [subprocess.Popen(command(folder, configs=CONFIGS / f"{name}.yaml"), cwd=REPO, env=environ(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for name in TOGETHER]
    errors = [(p.wait(timeout=300), p.stderr.read() if p.stderr else "") for p in procs]
    problems = [f"exit {code}: {err.strip()}" for code, err in errors if code != 0]
    listed = json.loads((folder / "manifest.json").read_text())["experiments"]
    problems += [f"{name} not in the manifest" for name in TOGETHER if name not in listed]
    for entry in listed.values():
        for name, art in entry["artifacts"].items():
            data = (folder / name).read_bytes() if (folder / name).is_file() else b""
            if hashlib.sha256(data).hexdigest() != art["sha256"]:
                problems.append(f"{name} differs from the manifest")
    timing = json.loads((folder / "timing.json").read_text())
    problems += [f"{name} not in timing.json" for name in TOGETHER if name not in timing]
    return "; ".join(problems)


def kill_section(root: Path, kills: int, seed: int) -> list[str]:
    """The kill trials: prints their counts, returns their failures."""
    refs = references(root)
    print(f"clean run over the old folder: {refs.seconds:.2f} s; {len(refs.points)} write-type system calls")
    counts: dict[str, int] = {}
    failures = []
    for i, point in enumerate(kill_points(refs, kills, seed)):
        folder = root / f"kill{i}"
        where, seen, code = kill_trial(folder, refs, point)
        if seen in ("old", "new"):
            again = after_kill(folder, refs)
            if again != "new":
                seen = f"the next run: {again}"
        counts[seen if seen in ("old", "new") else "FAILED"] = counts.get(seen, 0) + 1
        if seen not in ("old", "new"):
            failures.append(f"kill at {where} (exit {code}): {seen}")
        shutil.rmtree(folder)
    print(f"kill trials: {kills}; folder exactly old: {counts.get('old', 0)}, exactly new: "
          f"{counts.get('new', 0)}, anything else: {counts.get('FAILED', 0)}")
    return failures


def together_section(root: Path, trials: int) -> list[str]:
    """The three-runs-at-once trials: prints their count, returns their failures."""
    failures = []
    for i in range(trials):
        problem = together_trial(root / f"together{i}")
        if problem:
            failures.append(f"three runs at once, trial {i}: {problem}")
    print(f"three runs into one folder at once: {trials} trials, {trials - len(failures)} with every "
          f"experiment listed and every file as listed, {len(failures)} not")
    return failures


def attack_section(names: list[str]) -> tuple[list[str], dict[str, int]]:
    """The attack trials named (in their own order): one line each as it ends; returns the failures and the
    tally of PASS, FAIL and SKIP."""
    from benchmarks.attacks import TRIALS
    from benchmarks.attacks.kit import attempt, line, trial_folder

    tally = {"PASS": 0, "FAIL": 0, "SKIP": 0}
    failures = []
    with trial_folder(Path(tempfile.gettempdir()), "stackx-attacks") as base:
        for trial in (t for t in TRIALS if t.name in names):
            outcome = attempt(trial, base)
            shown = line(trial.name, outcome)
            print(shown, flush=True)
            tally[shown.split()[1]] += 1
            if outcome.passed is False:
                failures.append(f"attack {trial.name}: {outcome.figure}")
    return failures, tally


def _attacks(value: str) -> list[str]:
    """``--attacks``: all, none, or names separated by commas (each one of the trials)."""
    from benchmarks.attacks import BY_NAME

    if value in ("all", "none"):
        return list(BY_NAME) if value == "all" else []
    names = [n.strip() for n in value.split(",") if n.strip()]
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown trial {unknown[0]!r}; trials: {', '.join(BY_NAME)}")
    return names


def _stop(signum: int, frame: object) -> None:
    """SIGTERM (``timeout``, a CI job cancelled): unwind, so every trial takes down its mounts and folders."""
    sys.exit(128 + signum)


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.robust_folder", description=__doc__.split("\n\n")[0])
    parser.add_argument("--kills", type=int, default=50, help="kill trials (default 50)")
    parser.add_argument("--together", type=int, default=20, help="three-runs-at-once trials (default 20)")
    parser.add_argument("--attacks", type=_attacks, default="all", metavar="all|none|NAME,...",
                        help="attack trials to run (default all; see benchmarks/attacks/__init__.py)")
    parser.add_argument("--seed", type=int, default=31)
    args = parser.parse_args()
    signal.signal(signal.SIGTERM, _stop)
    failures: list[str] = []
    tally = {}
    if args.kills or args.together:
        with tempfile.TemporaryDirectory(prefix="stackx-folder-") as tmp:
            root = Path(tmp)
            failures += kill_section(root, args.kills, args.seed) if args.kills else []
            failures += together_section(root, args.together) if args.together else []
    if args.attacks:
        attack_failures, tally = attack_section(args.attacks)
        failures += attack_failures
    for line in failures:
        print("FAILED", line)
    summary = f"{len(failures)} failure(s)"
    if tally:
        summary += f"; attack trials: {tally['PASS']} PASS, {tally['FAIL']} FAIL, {tally['SKIP']} SKIP"
    print(f"summary: {args.kills} kill trials, {args.together} three-runs-at-once trials, {len(args.attacks)} "
          f"attack trials; {summary}")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
