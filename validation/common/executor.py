"""Run independent tasks on a Dask cluster (or in this process) and hand back each one as it ends.

The one executor of ``demes sweep`` and ``demes validate``: a :class:`distributed.LocalCluster`
on this machine by default, any running cluster by its scheduler address, or this process
(``workers <= 1``, no cluster). Tasks write their own results to disk as they finish, so a
worker that dies loses only the task it was running: the scheduler re-runs that task on
another worker, and the task skips what is already on disk.
"""

from __future__ import annotations

import asyncio
import logging
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

from tqdm import tqdm

DEFAULT_WORKERS = 2
"""Worker processes of the default LocalCluster (one thread each: the solvers are serial)."""

POLL_SECONDS = 2.0
"""How often the progress bar asks ``poll`` how far the running tasks are."""


@dataclass(frozen=True)
class Outcome:
    """How one task ended: its ``value``, or the ``error`` (text) that stopped it."""

    task: Any
    value: Any = None
    error: str | None = None


@contextmanager
def connect(scheduler: str | None = None, workers: int = DEFAULT_WORKERS) -> Iterator[Any]:
    """A Dask client: to ``scheduler`` (e.g. ``tcp://host:8786``) if given, else to a new
    LocalCluster of ``workers`` single-threaded processes; ``None`` (run in this process) when
    ``workers <= 1`` and no scheduler is given. The LocalCluster is closed on exit."""
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
            yield client
        return
    if workers <= 1:
        yield None
        return
    # no dashboard (its port may be taken by another cluster) and no routine log lines
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        yield client


def run_tasks(fn: Callable[..., Any], tasks: Sequence[Any], *, client: Any = None,
              args: tuple = (), weight: Callable[[Any], int] = lambda task: 1,
              total: int | None = None, done: int = 0, desc: str = "", unit: str = "task",
              progress: bool = True, poll: Callable[[], int] | None = None) -> Iterator[Outcome]:
    """``fn(task, *args)`` for every task, yielded as each finishes (in any order).

    Parameters
    ----------
    client
        From :func:`connect`; ``None`` runs the tasks here, one after another.
    weight
        How many progress-bar units a task counts for (e.g. its number of grid points).
    total, done
        Bar length and units already done before this call (a resumed study).
    poll
        Units done so far, all tasks together (e.g. records on disk): asked every
        :data:`POLL_SECONDS` on a cluster, so the bar moves while long tasks run.

    A task that raises (or whose worker died more often than Dask allows) yields an
    :class:`Outcome` with ``error`` set; the other tasks go on.
    """
    total = sum(weight(t) for t in tasks) + done if total is None else total
    bar = tqdm(total=total, initial=done, desc=desc, unit=unit, disable=not progress)

    def advance(outcome: Outcome | None) -> None:
        if poll is not None:
            bar.n = poll()
            bar.refresh()
        elif outcome is not None:
            bar.update(weight(outcome.task))

    try:
        for outcome in _outcomes(fn, tasks, client, args, lambda: advance(None)):
            advance(outcome)
            yield outcome
    finally:
        bar.close()


def _outcomes(fn: Callable[..., Any], tasks: Sequence[Any], client: Any, args: tuple,
              tick: Callable[[], None]) -> Iterator[Outcome]:
    if client is None:
        for task in tasks:
            try:
                yield Outcome(task, fn(task, *args))
            except Exception as exc:  # one failed task is reported, not the end of the others
                yield Outcome(task, error=f"{type(exc).__name__}: {exc}")
        return
    from distributed import wait

    # pure=False: a task re-submitted after an interruption runs again (it resumes from disk)
    futures = {client.submit(fn, task, *args, pure=False): task for task in tasks}
    pending = set(futures)
    while pending:
        try:
            finished, pending = wait(pending, timeout=POLL_SECONDS, return_when="FIRST_COMPLETED")
        except (TimeoutError, asyncio.TimeoutError):  # the same class from Python 3.11 on
            tick()
            continue
        for future in finished:
            task = futures.pop(future)
            try:
                yield Outcome(task, future.result())
            except Exception as exc:
                yield Outcome(task, error=f"{type(exc).__name__}: {exc}")
            future.release()
