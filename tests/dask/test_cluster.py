"""``--executor dask`` on a real cluster: a local one of two worker processes, as Dask runs on a laptop.

A sweep and a bench run on it write what they write in this process, byte for byte, but for wall clocks:
``timing.json`` (microseconds per step, measured wherever the runs step) and the bench's times per step
(``us_per_step``, ``us_per_call``, ``timing``), with what is derived from them (Pareto fronts, equal-cost
winners, the plots and their tables, the total wall time). The bench test puts the local run's times into
the cluster's records and writes both: then every file must be identical. A worker killed mid-sweep loses
its chunk to another worker, and the result is still complete and identical.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed", reason="needs Dask: python3 -m pip install -e '.[test,dask]'")

from stackx.bench.command import bench  # noqa: E402
from stackx.bench.report import CaseResult, write  # noqa: E402
from stackx.config.experiment import load  # noqa: E402
from stackx.run.executor import Choice, open_executor  # noqa: E402
from stackx.output.outdir import OutputDir  # noqa: E402
from stackx.run.runner import run_experiment  # noqa: E402
from stackx.run.session import run_all, stage  # noqa: E402
from tests.conftest import REPO, Cli  # noqa: E402
from tests.dask.configs import SWEEP, write as write_config  # noqa: E402

TIMED = ("us_per_step", "us_per_call", "timing")  # a bench record's wall-clock fields


@pytest.fixture(scope="module")
def cluster() -> Iterator[distributed.Client]:
    """Two single-threaded worker processes on this machine; the client of the test, not of the runs."""
    local = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                     silence_logs=logging.ERROR)
    client = distributed.Client(local)
    yield client
    client.close()
    local.close()


def _executed(client: distributed.Client) -> dict[str, int]:
    return client.run(lambda dask_worker: dask_worker.state.executed_count)  # type: ignore[no-any-return]


def _prefix(client: distributed.Client, prefix: str) -> tuple[int, int]:
    """Tasks of a key prefix the scheduler has seen finish, and how often a worker died under one."""
    def read(dask_scheduler: distributed.Scheduler) -> tuple[int, int]:
        found = dask_scheduler.task_prefixes.get(prefix)
        return (0, 0) if found is None else (found.state_counts["memory"], found.suspicious)
    return client.run_on_scheduler(read)  # type: ignore[no-any-return]


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_sweep_on_the_cluster_writes_what_it_writes_here(cluster: distributed.Client, cli: Cli,
                                                           tmp_path: Path) -> None:
    """The command line with DASK_SCHEDULER_ADDRESS set: 12 runs in chunks of one (four per worker thread),
    stepped by both workers; every file but timing.json byte-identical, the manifest included."""
    config = write_config(tmp_path, "sweep", SWEEP)
    run_all([load(str(config))], tmp_path / "here", quiet=True)
    before, (chunks_before, _) = _executed(cluster), _prefix(cluster, "stackx-chunk")
    there = cli("run", config, "--out", tmp_path / "there", "-q", "--executor", "dask",
                env={"DASK_SCHEDULER_ADDRESS": cluster.scheduler.address})
    assert there.returncode == 0, there.stderr
    after, (chunks_after, _) = _executed(cluster), _prefix(cluster, "stackx-chunk")
    assert chunks_after - chunks_before == 12
    assert all(after[w] > before.get(w, 0) for w in after), (before, after)

    local, remote = _files(tmp_path / "here"), _files(tmp_path / "there")
    assert sorted(local) == sorted(remote) and {"manifest.json", "timing.json", "f05.png", "index.html"} <= set(local)
    assert [name for name in local if name != "timing.json" and local[name] != remote[name]] == []


def test_a_bench_on_the_cluster_gives_the_same_records_and_report(cluster: distributed.Client, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Two cases (one that blows up) x the lab solver and the example local plugin 'sor', which the workers
    import from its file. Kernels run plain (STACKX_JIT=0, sent with every task) to keep it short."""
    monkeypatch.setenv("STACKX_JIT", "0")
    cases = tmp_path / "cases"
    cases.mkdir()
    knobs = "bench: {knob: [2, 16], timing: {steps: 20, repeats: 2}}\n"
    (cases / "tall-6.yaml").write_text("scene: {name: column, stack: {count: 6, y0: 0.501, spacing: 1.0}}\n"
                                       "solver: {name: pgs}\nsteps: 90\n" + knobs)
    (cases / "drop.yaml").write_text("scene: {name: column, boxes: [{y: 0.5}, {y: 30.0}]}\nsolver: {name: pgs}\n"
                                     "steps: 60\nlimits: {max_speed: 5}\n" + knobs)
    args = ([str(cases)], ["pgs", "sor"])
    kw = {"plugins": REPO / "plugins", "quiet": True}
    local = bench(*args, tmp_path / "here", **kw)  # type: ignore[arg-type]
    before = _prefix(cluster, "stackx-call")[0]
    remote = bench(*args, tmp_path / "there", choice=Choice("dask", cluster.scheduler.address), **kw)  # type: ignore[arg-type]
    assert _prefix(cluster, "stackx-call")[0] - before == 4  # 2 cases x 2 solvers, one task each

    records = [r for res in remote for r in res.records]
    assert len(records) == 10 and sum(bool(r.blew_up) for r in records) == 5  # pgs at 2, 10 (its own), 16
    assert all(r.us_per_step is not None for r in records)  # timed on the workers
    timed = []
    for mine, theirs in zip(local, remote):
        assert len(mine.records) == len(theirs.records)
        same_clock = [dataclasses.replace(t, **{k: getattr(m, k) for k in TIMED})
                      for m, t in zip(mine.records, theirs.records)]
        timed.append(CaseResult.build(theirs.case, same_clock, theirs.left_out))
    written = {}
    for name, results in (("here", local), ("there", timed)):
        out = OutputDir(tmp_path / name)
        write(results, out, "stackx bench", 1.0)
        written[name] = out.staged
    assert sorted(written["here"]) == sorted(written["there"]) and "report.html" in written["here"]
    assert [name for name in written["here"] if written["here"][name] != written["there"][name]] == []


def test_a_worker_killed_mid_sweep_loses_nothing(cluster: distributed.Client, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """12 runs of a 16-box column in chunks of 2, stepped plain (about a fifth of a second a chunk on an idle
    core). When the first chunk comes back, a worker busy with another is killed (SIGKILL): the scheduler
    sends that chunk to a worker alive, and the result is complete and identical to this process's run."""
    config = write_config(tmp_path, "tall", """
scene: {name: column, stack: {count: 16, y0: 0.52, spacing: 1.02}}
solver: {name: pgs, iterations: 15}
steps: 300
sweep: {name: "v{index}", grid: {solver.correction.percent: [0.1, 0.2, 0.4], solver.iterations: [6, 8, 10, 12]}}
outputs:
  - {sink: keyvalue, path: tall.txt, values: {top: "v0.y[-1]", low: v11.max_depth}}
  - {sink: metrics, path: tall.metrics.json}
""")
    monkeypatch.setenv("STACKX_JIT", "0")
    spec = load(str(config))
    whole = stage(spec, run_experiment(spec), tmp_path).staged
    pids = cluster.run(os.getpid)
    _, died_before = _prefix(cluster, "stackx-chunk")
    killed: list[str] = []
    reported: list[int] = []

    def kill_one(steps: int) -> None:
        reported.append(steps)
        if killed:
            return
        busy = [w for w, keys in cluster.processing().items() if any("stackx-chunk" in str(k) for k in keys)]
        assert busy, "no worker was stepping a chunk when the first one came back"
        killed.append(busy[0])
        os.kill(pids[busy[0]], signal.SIGKILL)

    with open_executor(Choice("dask", cluster.scheduler.address, chunk=2)) as executor:
        (job,) = executor.experiments([spec])
        result = job.result(kill_one)
    _, died_after = _prefix(cluster, "stackx-chunk")
    assert killed and died_after > died_before  # a chunk was lost with its worker, and run again
    assert reported == [2 * 300] * 6  # the progress bar: each chunk's steps, once, when it came back
    assert [r.name for r in result.runs] == [r.name for r in spec.runs]
    again = stage(spec, result, tmp_path).staged
    assert sorted(again) == sorted(whole) == ["tall.metrics.json", "tall.txt"]
    assert again == whole
