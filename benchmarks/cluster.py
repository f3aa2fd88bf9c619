"""Sweeps past one machine: a sweep of scene 06 stepped here in batches, against a local Dask cluster of 1 and 2
workers, with what each part costs, and what a cluster of 100 workers would do with those costs.

    python3 -m benchmarks.cluster [--variants 1000000] [--chunk RUNS] [--workers 1,2] [--json out/cluster.json]

The sweep is configs/06-stack.yaml (five boxes, 900 steps, the lab solver at 15 iterations) over 100 slops x
100 percents x ``variants / 10,000`` gravities (-9.30, -9.31, ...): every variant costs what scene 06 costs.
It has no outputs (a million runs' metrics would be a file of gigabytes) and raises ``limits.max_memory_mb``,
which counts the states a local run of the whole sweep as one batch would keep.

Timed, one after another, each on the same loaded config:

- **load**: validating the config (one resolved run per variant), in this process: serial on any cluster;
- **local**: ``run_experiment`` on consecutive slices of ``--chunk`` runs, each one compiled batch over every
  core (the whole sweep as one batch would keep some 12 GiB of recorded states);
- **cluster, W workers**: ``--executor dask`` on a ``LocalCluster`` of W single-threaded worker processes:
  cutting and pickling the chunks (**submit**), then waiting for them while gathering and merging
  (**collect**); Dask's task stream gives each chunk's time on its worker (unpickling, stepping, measuring).

Every cluster run is checked against the local one on every 997th variant, bit for bit. The projection for
100 workers takes the measured per-variant costs (load, submit, merge on the client; a chunk's compute on a
worker, which is per variant, with the measured fixed cost per task) and adds nothing this machine cannot
show: a network's transfer time is estimated from the bytes each chunk sends and returns at 1 Gbit/s.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console
from rich.table import Table

from benchmarks.run import SCENE_06, _busy_cores, _machine

console = Console()
PER_GRAVITY = 10_000  # 100 slops x 100 percents
SAMPLE = 997  # every SAMPLE-th variant is compared between local and cluster runs
PROJECTED_WORKERS = 100
NETWORK = 125e6  # bytes per second: 1 Gbit/s between the client and the workers, for the projection


def write_config(folder: Path, variants: int) -> Path:
    doc = yaml.safe_load(SCENE_06.read_text())
    grid = {"solver.correction.slop": [round(0.0002 * i, 4) for i in range(100)],
            "solver.correction.percent": [round(0.01 * (i + 1), 2) for i in range(100)],
            "gravity": [round(-9.30 - 0.01 * i, 2) for i in range(variants // PER_GRAVITY)]}
    doc.update(outputs=[], sweep={"name": "v{index}", "grid": grid}, limits={"max_memory_mb": 1e8})
    path = folder / "sweep-06.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def sample_of(result: Any) -> dict[str, Any]:
    return {r.name: r.measures for r in result.runs[::SAMPLE]}


def local(spec: Any, rows: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """The sweep stepped here, slice by slice; the measures of the sampled variants."""
    import dataclasses

    from stackx.run.runner import run_experiment

    seen: dict[str, Any] = {}
    wanted = {r.name for r in spec.runs[::SAMPLE]}
    t0 = time.perf_counter()
    stepping = 0.0
    for first in range(0, len(spec.runs), rows):
        part = dataclasses.replace(spec, runs=spec.runs[first:first + rows])
        result = run_experiment(part)
        stepping += sum(r.wall_seconds for r in result.runs)
        seen.update((r.name, r.measures) for r in result.runs if r.name in wanted)
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "stepping_s": stepping, "slices": math.ceil(len(spec.runs) / rows), "rows": rows}, seen


def cluster(spec: Any, workers: int, rows: int | None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The sweep on a LocalCluster of ``workers`` single-threaded processes, as ``--executor dask`` runs it."""
    import pickle

    from distributed import Client, LocalCluster, get_task_stream

    from stackx.run.cluster import Cluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as local_cluster, Client(local_cluster) as client:
        executor = Cluster(client, rows)
        with get_task_stream(client) as stream:
            t0 = time.perf_counter()
            (job,) = executor.experiments([spec])
            submitted = time.perf_counter()
            result = job.result()
            done = time.perf_counter()
        tasks = [t for t in stream.data if str(t["key"]).startswith("stackx-chunk")]
    parts = job.parts  # type: ignore[attr-defined]
    compute = sorted(sum(s["stop"] - s["start"] for s in t["startstops"] if s["action"] == "compute") for t in tasks)
    payload = statistics.mean(len(pickle.dumps((p,), protocol=pickle.HIGHEST_PROTOCOL)) for p in parts[:3])
    figures = {
        "workers": workers, "chunks": len(parts), "rows_per_chunk": len(parts[0].plan.runs),
        "wall_s": done - t0, "submit_s": submitted - t0, "collect_s": done - submitted,
        "chunk_compute_s": {"median": statistics.median(compute), "min": compute[0], "max": compute[-1],
                            "sum": sum(compute)},
        "payload_bytes_per_run": payload / len(parts[0].plan.runs),
    }
    return figures, sample_of(result)


def merging(spec: Any, rows: int = 2000) -> dict[str, float]:
    """What the client does per variant with a chunk's result: unpickle it and merge it (``chunks.merge``), and
    the bytes a chunk sends back per variant; on one chunk of ``rows`` stepped here."""
    import dataclasses
    import pickle

    from stackx.run import chunks

    (part,) = chunks.split(dataclasses.replace(spec, runs=spec.runs[:rows]), rows)
    wire = pickle.dumps(chunks.run_chunk(part), protocol=pickle.HIGHEST_PROTOCOL)
    t0 = time.perf_counter()
    chunks.merge(part.plan, [part], [pickle.loads(wire)])
    return {"merge_s_per_run": (time.perf_counter() - t0) / rows, "result_bytes_per_run": len(wire) / rows}


def project(n: int, load_s: float, single: dict[str, Any], best: dict[str, Any],
            merge: dict[str, float]) -> dict[str, Any]:
    """What 100 workers would do with the measured costs: the client's serial work (load, submit), then the
    longest of the workers' rounds of chunks, the client's unpickling and merging of every result, and the
    bytes on a 1 Gbit/s network."""
    from stackx.run.chunks import TASKS_PER_THREAD

    per_variant = single["chunk_compute_s"]["sum"] / n  # one worker, alone on its core
    fixed = max(0.0, (single["collect_s"] - single["chunk_compute_s"]["sum"]) / single["chunks"])
    rows = math.ceil(n / (TASKS_PER_THREAD * PROJECTED_WORKERS))
    tasks = math.ceil(n / rows)
    rounds = math.ceil(tasks / PROJECTED_WORKERS)
    compute = rounds * (rows * per_variant + fixed)
    submit = best["submit_s"]  # cutting and pickling every chunk: per variant, whatever the workers
    merged = merge["merge_s_per_run"] * n
    network = n * (best["payload_bytes_per_run"] + merge["result_bytes_per_run"]) / NETWORK
    return {"workers": PROJECTED_WORKERS, "rows_per_chunk": rows, "chunks": tasks, "rounds": rounds,
            "compute_us_per_variant": per_variant * 1e6, "fixed_s_per_task": fixed, "load_s": load_s,
            "submit_s": submit, "compute_s": compute, "client_merge_s": merged, "network_s": network,
            "total_s": load_s + submit + max(compute, merged, network)}


def main() -> None:
    parser = argparse.ArgumentParser(prog="python3 -m benchmarks.cluster", description=__doc__.split("\n\n")[0])
    parser.add_argument("--variants", type=int, default=1_000_000, help="a multiple of 10,000 (default 1,000,000)")
    parser.add_argument("--chunk", type=int, default=None,
                        help="runs per chunk and per local slice (default: the executor's choice for 2 workers)")
    parser.add_argument("--workers", default="1,2", help="cluster sizes to time, comma-separated (default 1,2)")
    parser.add_argument("--json", type=Path, default=Path("out/cluster.json"), help="where the figures go")
    args = parser.parse_args()
    if args.variants < PER_GRAVITY or args.variants % PER_GRAVITY:
        parser.error("--variants must be a positive multiple of 10,000")
    sizes = [int(w) for w in args.workers.split(",")]

    from stackx.run import chunks
    from stackx.config.experiment import load
    from stackx.run.runner import batches

    doc: dict[str, Any] = {"machine": _machine(), "variants": args.variants, "busy_cores_before": _busy_cores()}
    # cores other processes kept busy just before each section: the figures mean little when it is not near 0
    with tempfile.TemporaryDirectory(prefix="stackx-cluster-") as tmp:
        path = write_config(Path(tmp), args.variants)
        t0 = time.perf_counter()
        spec = load(str(path))
        doc["load_s"] = time.perf_counter() - t0
    n = len(spec.runs)
    console.print(f"load: {n:,} variants validated in {doc['load_s']:.1f} s ({doc['load_s'] / n * 1e6:.0f} µs each)")
    rows = args.chunk or chunks.chunk_rows(batches(spec.runs), set(), 2)
    busy = _busy_cores()
    doc["local"], reference = local(spec, rows)
    doc["local"]["busy_cores_before"] = busy
    console.print(f"local: {doc['local']['wall_s']:.1f} s in {doc['local']['slices']} slices of {rows:,}")
    doc["cluster"] = []
    for workers in sizes:
        busy = _busy_cores()
        figures, sample = cluster(spec, workers, rows)
        figures["busy_cores_before"] = busy
        figures["identical_to_local"] = sample == reference
        doc["cluster"].append(figures)
        console.print(f"cluster of {workers}: {figures['wall_s']:.1f} s, identical: {figures['identical_to_local']}")
    single = next((c for c in doc["cluster"] if c["workers"] == 1), doc["cluster"][0])
    doc["merge"] = merging(spec)
    doc["projection"] = project(n, doc["load_s"], single, doc["cluster"][-1], doc["merge"])
    report(doc, n)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    console.print(f"figures written to {args.json}")


def report(doc: dict[str, Any], n: int) -> None:
    steps = 900 * n
    table = Table(title=f"sweep of {n:,} variants of scene 06 ({os.cpu_count()} cores)")
    for col in ("how", "wall s", "million scene-steps/s", "x local", "x 1 worker", "chunks", "median chunk s"):
        table.add_column(col, justify="left" if col == "how" else "right")
    loc = doc["local"]["wall_s"]
    one = next((c["wall_s"] for c in doc["cluster"] if c["workers"] == 1), None)
    table.add_row("local, batched over every core", f"{loc:.1f}", f"{steps / loc / 1e6:.2f}", "1", "-",
                  str(doc["local"]["slices"]), "-")
    for c in doc["cluster"]:
        table.add_row(f"Dask LocalCluster, {c['workers']} worker(s)", f"{c['wall_s']:.1f}",
                      f"{steps / c['wall_s'] / 1e6:.2f}", f"{loc / c['wall_s']:.2f}",
                      f"{one / c['wall_s']:.2f}" if one else "-", str(c["chunks"]),
                      f"{c['chunk_compute_s']['median']:.2f}")
    console.print(table)
    p = doc["projection"]
    console.print(f"100 workers, on paper: {p['chunks']} chunks of {p['rows_per_chunk']:,} in {p['rounds']} rounds: "
                  f"load {p['load_s']:.0f} s + submit {p['submit_s']:.0f} s + max(compute {p['compute_s']:.1f} s, "
                  f"client merge {p['client_merge_s']:.0f} s, network {p['network_s']:.1f} s) = {p['total_s']:.0f} s")


if __name__ == "__main__":
    main()
