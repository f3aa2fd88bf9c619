"""The ``dask`` executor: a sweep's chunks and a bench's solvers stepped by the workers of a Dask cluster.

Dask's distributed scheduler does the distributing: which worker runs what, moving results, noticing a
worker that died. Its ``Client`` connects to a scheduler's address (``--scheduler``, else the
``DASK_SCHEDULER_ADDRESS`` variable, Dask's own convention), or, given none, starts a local cluster on this
machine: one worker process per core, one thread each. The same command runs on a laptop and on a cluster.

A task carries its arguments pickled by stackx, beside the local plugin files this process imported
(``stackx.registry.local_modules``, their source included) and the ``STACKX_JIT`` settings: the worker
imports those files under the names they have here before unpickling, so runs of a local solver arrive as
they left. A chunk also carries the part of its batch's work it holds (``Chunk.share``), so that the worker
compiles it when the whole batch would compile here, not by the chunk's own size. The scheduler and the
workers need stackx itself installed, the same version (Dask unpickles a task's function on both). A worker
steps each task on one core (``stackx.kernel.threads``): Dask gives a machine one task per core, so threads
per task would only compete.

Failures. A run that blows up or a plugin that raises is a result, not an exception: it is sent back and
reported as a local run reports it (``stackx.run.chunks.failure``). Anything else a task raises (out of memory, a
module missing on a worker) is retried ``RETRIES`` times (Dask's ``retries=``). A worker that dies mid-task is
the scheduler's business: its tasks go to other workers, up to the scheduler's
``distributed.scheduler.allowed-failures`` deaths per task (3 by default), after which the task fails with
``KilledWorker``. Results are gathered once per task and written by this process only, so a task run twice
writes nothing twice.
"""

from __future__ import annotations

import logging
import os
import pickle
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Generic, TypeVar

from distributed import Client, Future, LocalCluster, as_completed

from stackx import kernel, registry
from stackx.run import chunks
from stackx.errors import ConfigError, RunError, first_line
from stackx.run.results import ExperimentResult
from stackx.run.runner import Progress, tell
from stackx.config.spec import Plan

R = TypeVar("R")

RETRIES = 2  # more tries of a task that raised something other than a run's own failure
CONNECT_TIMEOUT = 10.0  # seconds to wait for a scheduler to accept a connection, and again for its greeting
GREETING_LIMIT = 1 << 20  # bytes: a scheduler's greeting is a few hundred; an HTTP answer read as a length is not


def connect_timeout() -> float:
    """``CONNECT_TIMEOUT``, or Dask's own setting when given in its environment variable
    (``DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT=3s``)."""
    from dask.utils import parse_timedelta

    given = os.environ.get("DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT")
    try:
        return float(parse_timedelta(given)) if given else CONNECT_TIMEOUT
    except (TypeError, ValueError, KeyError):
        raise ConfigError(f"DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT: not a duration: {given!r}") from None


def greeted(address: str, timeout: float) -> None:
    """Check, before Dask's client does, that a plain TCP ``address`` leads to a Dask scheduler.

    A Dask scheduler greets a new connection first: one message, a 64-bit length and that many bytes of
    frames. Dask's client trusts that length (an HTTP server's answer read as one asks for exabytes) and waits
    for the greeting without a time limit (a server that accepts and stays silent hangs it). Here the
    connection and the greeting each get ``timeout`` seconds, and a greeting must be shaped like Dask's: a
    short message whose frame count and frame lengths add up. Addresses of other schemes (``tls://``,
    ``inproc://``...) are left to Dask.
    """
    import socket
    import struct

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme != "tcp":
            return
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"--scheduler {address}: not a scheduler address ({first_line(exc)}); e.g. "
                          f"tcp://10.0.0.5:8786") from None

    def refuse(why: str) -> ConfigError:
        return ConfigError(f"--scheduler {address}: {why}")

    try:
        conn = socket.create_connection((host, port), timeout=timeout)
    except TimeoutError:
        raise refuse(f"nothing accepted a connection in {timeout:g} s") from None
    except (OSError, OverflowError) as exc:
        raise refuse(f"no Dask scheduler answered: {getattr(exc, 'strerror', None) or exc}") from None
    with conn:
        conn.settimeout(timeout)
        try:
            head = _read(conn, 8)
            size = struct.unpack("<Q", head)[0] if len(head) == 8 else 0
            if len(head) == 8 and 16 <= size <= GREETING_LIMIT:
                body = _read(conn, size)
                if len(body) == size and _frames_add_up(body):
                    return
            elif len(head) == 8:
                conn.settimeout(0.2)  # a little more of what it said, to show
                try:
                    head += conn.recv(24)
                except OSError:
                    pass
        except TimeoutError:
            raise refuse(f"the server accepted the connection but sent nothing in {timeout:g} s, where a Dask "
                         f"scheduler greets at once: not a Dask scheduler (or a very slow one)") from None
        except OSError as exc:
            raise refuse(f"the connection failed while waiting for the scheduler's greeting: "
                         f"{exc.strerror or exc}") from None
    seen = head[:32].decode("latin-1") if head else ""
    raise refuse(f"the server there does not speak Dask's protocol (it sent {seen!r}...): not a Dask scheduler"
                 if head else "the server closed the connection without a greeting: not a Dask scheduler")


def _read(conn: Any, n: int) -> bytes:
    """Up to ``n`` bytes, fewer only when the peer closed."""
    data = b""
    while len(data) < n:
        chunk = conn.recv(min(n - len(data), 65536))
        if not chunk:
            break
        data += chunk
    return data


def _frames_add_up(body: bytes) -> bool:
    """Dask's frame layout: a frame count, that many lengths, then frames whose lengths sum to the rest."""
    import struct

    count = struct.unpack_from("<Q", body)[0]
    if not 1 <= count <= 64 or len(body) < 8 * (count + 1):
        return False
    lengths = struct.unpack_from(f"<{count}Q", body, 8)
    return sum(lengths) <= len(body) - 8 * (count + 1)


@contextmanager
def connect(address: str | None, chunk: int | None = None) -> Iterator[Cluster]:
    """A cluster to run on: the scheduler at ``address``, or a local cluster started here (and stopped after)."""
    started = None
    if address is None:
        started = LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.CRITICAL)
        client = Client(started)
    else:
        greeted(address, connect_timeout())
        try:
            client = Client(address, timeout=connect_timeout())
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"--scheduler {address}: no Dask scheduler answered: {first_line(exc)}") from None
    try:
        yield Cluster(client, chunk)
    finally:
        client.close()
        if started is not None:
            started.close()


class Cluster:
    """Hands work to the workers of ``client``; ``chunk`` rows per task of a sweep (None: ``chunk_rows``)."""

    def __init__(self, client: Client, chunk: int | None = None) -> None:
        self.client, self.chunk = client, chunk

    def threads(self) -> int:
        """Worker threads in the cluster now: tasks it runs at once."""
        return sum(self.client.nthreads().values())

    def experiments(self, plans: Sequence[Plan]) -> list[_Experiment]:
        jobs = []
        threads = self.threads()
        for plan in plans:
            parts = chunks.split(plan, self.chunk, threads)
            jobs.append(_Experiment(self, plan, parts, [self.submit("stackx-chunk", chunks.run_chunk, (c,))
                                                        for c in parts]))
        return jobs

    def calls(self, fn: Callable[..., R], args: Sequence[tuple[Any, ...]],
              weights: Sequence[int]) -> list[_Call[R]]:
        return [_Call(self.submit("stackx-call", fn, a), w, f"{fn.__module__}.{fn.__qualname__}")
                for a, w in zip(args, weights)]

    def submit(self, kind: str, fn: Callable[..., Any], args: tuple[Any, ...]) -> Future:
        """One task: ``fn(*args)`` on a worker, ``args`` pickled here (see the module doc)."""
        payload = pickle.dumps(args, protocol=pickle.HIGHEST_PROTOCOL)
        environ = {name: os.environ.get(name) for name in kernel.SETTINGS}
        return self.client.submit(_task, registry.local_modules(), environ, fn, payload,
                                  key=f"{kind}-{uuid.uuid4().hex}", retries=RETRIES, pure=False)

    def rerun(self, work: list[tuple[chunks.Chunk, int]]) -> list[list[dict[str, Any]]]:
        """Chunks stepped again to a step, for a failed-run report (``stackx.run.chunks.states_at``)."""
        futures = [self.submit("stackx-again", chunks.states_at, item) for item in work]
        try:
            return self.client.gather(futures)  # type: ignore[no-any-return]
        except Exception as exc:
            raise RunError(f"stepping runs again to report a blow-up failed on the Dask cluster: "
                           f"{first_line(exc)}") from exc


def _task(modules: list[registry.LocalModule], environ: dict[str, str | None], fn: Callable[..., Any],
          payload: bytes) -> Any:
    """On a worker: import this sender's local plugins, take its settings, unpickle, run on one core."""
    spare = kernel.cache_root() / "plugins"
    for module in modules:
        registry.import_local(module, spare)
    args = pickle.loads(payload)
    with kernel.settings(environ), kernel.threads(1):
        return fn(*args)


class _Experiment:
    """One plan's chunks on the cluster; ``result`` gathers them as they finish and merges them in order."""

    def __init__(self, cluster: Cluster, plan: Plan, parts: list[chunks.Chunk], futures: list[Future]) -> None:
        self.cluster, self.plan, self.parts, self.futures = cluster, plan, parts, futures

    def result(self, progress: Progress | None = None) -> ExperimentResult:
        parts, futures = self.parts, self.futures
        index = {f.key: i for i, f in enumerate(futures)}
        outcomes: dict[int, chunks.Stepped | chunks.Failed] = {}
        stop: int | None = None  # the first batch with a failed chunk: later batches are not needed
        try:
            for future in as_completed(futures):
                i = index[future.key]
                if stop is not None and parts[i].batch > stop:
                    continue
                try:
                    got = future.result()
                except Exception as exc:
                    names = parts[i].names
                    raise RunError(f"{self.plan.file}: run(s) {names[0]!r}..{names[-1]!r} failed on the Dask "
                                   f"cluster: {first_line(exc)}") from exc
                outcomes[i] = got
                if isinstance(got, chunks.Failed):
                    stop = min(stop, parts[i].batch) if stop is not None else parts[i].batch
                    self.cluster.client.cancel([f for j, f in enumerate(futures) if parts[j].batch > stop])
                elif progress is not None:
                    progress(parts[i].weight)
                if stop is not None and all(j in outcomes for j, p in enumerate(parts) if p.batch <= stop):
                    break
        finally:
            self.cluster.client.cancel([f for f in futures if not f.done()])
            self.futures = []  # the workers may drop what they hold for this plan
        if stop is not None:
            raise chunks.failure(self.plan, parts, outcomes, self.cluster.rerun)
        result = chunks.merge(self.plan, parts, [outcomes[i] for i in range(len(parts))])  # type: ignore[misc]
        tell(result.notes)  # a batch the workers stepped plain for long, with the switch
        return result


class _Call(Generic[R]):
    """One call on the cluster; its result counts ``weight`` steps of progress when it arrives."""

    def __init__(self, future: Future, weight: int, what: str) -> None:
        self.future, self.weight, self.what = future, weight, what

    def result(self, progress: Progress | None = None) -> R:
        try:
            got: R = self.future.result()
        except Exception as exc:
            raise RunError(f"{self.what} failed on the Dask cluster: {first_line(exc)}") from exc
        if progress is not None:
            progress(self.weight)
        return got
