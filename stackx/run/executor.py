"""Where runs step: in this process (``local``), or on the workers of a Dask cluster (``dask``).

``stackx run`` and ``stackx bench`` hand their work to an executor and get results back in their own order,
then write them as always: the executor changes where stepping happens, never what is written. Work is
handed over all at once (``experiments``, ``calls``), so a cluster can start on all of it; each job's result
is then asked for in order (``Job.result``), with a progress callback that the local executor feeds while
stepping and a cluster as its tasks finish.

The ``dask`` executor lives in ``stackx.run.cluster`` and is imported only when chosen: Dask is an optional extra
(``pip install 'stackx[dask]'``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from stackx.errors import ConfigError
from stackx.run.results import ExperimentResult
from stackx.run.runner import Progress, run_experiment, tell
from stackx.config.spec import Plan

R = TypeVar("R")
R_co = TypeVar("R_co", covariant=True)

EXECUTORS = ("local", "dask")
ADDRESS_VARIABLE = "DASK_SCHEDULER_ADDRESS"  # Dask's own convention for where its scheduler is
INSTALL = "python3 -m pip install 'dask[distributed]' (or: python3 -m pip install -e '.[dask]')"


class Job(Protocol[R_co]):
    """Work handed to an executor: ``result`` waits for it (or does it), feeding ``progress`` with steps done."""

    def result(self, progress: Progress | None = None) -> R_co: ...


class Executor(Protocol):
    def experiments(self, plans: Sequence[Plan]) -> list[Job[ExperimentResult]]:
        """Each plan stepped and measured, as ``run_experiment`` does it."""
        ...

    def calls(self, fn: Callable[..., R], args: Sequence[tuple[Any, ...]],
              weights: Sequence[int]) -> list[Job[R]]:
        """``fn(*a, progress=...)`` for each ``a`` of ``args``; ``weights`` the steps each reports when done."""
        ...


@dataclass(frozen=True)
class Choice:
    """The command line's choice: ``executor`` (local or dask), the Dask ``scheduler`` address (None: the
    ``DASK_SCHEDULER_ADDRESS`` variable, else a local cluster of one single-threaded worker per core) and the
    ``chunk`` rows per task of a sweep (None: see ``stackx.run.chunks.chunk_rows``)."""

    executor: str = "local"
    scheduler: str | None = None
    chunk: int | None = None

    def check(self) -> None:
        """Refuse a choice that cannot work, before anything runs (exit code 2)."""
        if self.executor not in EXECUTORS:
            raise ConfigError(f"--executor: unknown executor {self.executor!r}; allowed: {', '.join(EXECUTORS)}")
        if self.executor == "local" and self.scheduler is not None:
            raise ConfigError("--scheduler needs --executor dask (runs step in this process with --executor local)")
        if self.executor == "local" and self.chunk is not None:
            raise ConfigError("--chunk needs --executor dask (a local sweep steps as one batch)")
        if self.chunk is not None and self.chunk < 1:
            raise ConfigError(f"--chunk: must be at least 1 run per task, not {self.chunk}")
        if self.executor == "dask":
            try:
                import distributed  # noqa: F401
            except ImportError:
                raise ConfigError(f"--executor dask needs Dask's distributed scheduler: {INSTALL}") from None

    @property
    def address(self) -> str | None:
        return self.scheduler or os.environ.get(ADDRESS_VARIABLE) or None


@contextmanager
def open_executor(choice: Choice) -> Iterator[Executor]:
    """The executor ``choice`` names, for the duration of a command (a cluster it started is stopped after)."""
    choice.check()
    if choice.executor == "local":
        yield Local()
        return
    from stackx.run.cluster import connect

    with connect(choice.address, choice.chunk) as cluster:
        yield cluster


class Local:
    """Everything steps in this process, when its result is asked for, exactly as without an executor."""

    def experiments(self, plans: Sequence[Plan]) -> list[Job[ExperimentResult]]:
        return [_LocalExperiment(plan) for plan in plans]

    def calls(self, fn: Callable[..., R], args: Sequence[tuple[Any, ...]],
              weights: Sequence[int]) -> list[Job[R]]:
        return [_Later(fn, a) for a in args]


class _LocalExperiment:
    """A plan stepped in this process when its result is asked for; its notes told then."""

    def __init__(self, plan: Plan) -> None:
        self.plan = plan

    def result(self, progress: Progress | None = None) -> ExperimentResult:
        result = run_experiment(self.plan, progress)
        tell(result.notes)
        return result


class _Later(Generic[R]):
    """``fn(*args, progress)``, called when its result is asked for."""

    def __init__(self, fn: Callable[..., R], args: tuple[Any, ...]) -> None:
        self.fn, self.args = fn, args

    def result(self, progress: Progress | None = None) -> R:
        return self.fn(*self.args, progress)
