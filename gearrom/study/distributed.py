"""Run idempotent study tasks on dask.distributed: an embedded LocalCluster or an existing scheduler.

Both cases take the same path: :func:`cluster_client` yields a :class:`distributed.Client`, and
:func:`run_tasks` submits one future per task and collects them as they complete. The tasks write
their own result files (atomically, one per task) before they return, so the client only gathers
small summaries; a task whose worker dies is rescheduled by the scheduler, and one that the
scheduler gives up on (``KilledWorker``) is resubmitted here a bounded number of times. A task that
runs twice writes the same file twice with the same content, so every result is kept exactly once.
"""
from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from gearrom.errors import ConfigError, GearromError

log = logging.getLogger(__name__)
#: how long a client waits for an existing scheduler before the study stops [s]
CONNECT_TIMEOUT_S = 10.0
#: resubmissions of a task that the scheduler reported as killed (its worker died repeatedly)
MAX_RESUBMIT = 3
#: memory limit of each embedded worker (restarted by its nanny beyond 95 % of it)
WORKER_MEMORY = "4GiB"


class StudyError(GearromError, RuntimeError):
    """A study could not be carried out (failed tasks, an unreachable scheduler)."""


@contextlib.contextmanager
def cluster_client(scheduler: str | None = None, n_workers: int = 2) -> Iterator[Any]:
    """A dask client: connected to ``scheduler`` (``tcp://host:port``) or to an embedded LocalCluster.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running dask scheduler. None starts a LocalCluster of ``n_workers`` worker
        processes with one thread each (the ROM is single-threaded; the nanny sets single-threaded
        BLAS in the workers) and closes it on exit.
    n_workers : int
        Worker processes of the embedded cluster.

    Raises
    ------
    ConfigError
        The scheduler cannot be reached within :data:`CONNECT_TIMEOUT_S` (the message names
        ``--scheduler``).
    """
    from distributed import Client, LocalCluster

    if scheduler is None:
        # a bounded memory per worker: the nanny restarts a worker that outgrows it (the ROM's
        # constant-speed run leaves about 1 MB per run behind in the process) and its task reruns
        with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
                          memory_limit=WORKER_MEMORY) as cl, \
                Client(cl) as client:
            yield client
        return
    try:
        client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise ConfigError(f"--scheduler={scheduler!r}: cannot reach the dask scheduler ({text})") from None
    try:
        yield client
    finally:
        client.close()


def run_tasks(fn: Callable[[Any], Any], tasks: Sequence[Any], client, *, keys: Sequence[str] | None = None,
              progress: bool = True, desc: str = "tasks", on_result: Callable[[Any, int], None] | None = None) -> list:
    """Run ``fn(task)`` for every task on ``client``; results in the order of ``tasks``.

    Parameters
    ----------
    fn : callable
        Importable function (pickled by reference); it must be idempotent.
    tasks : sequence
        Picklable task descriptions.
    client : distributed.Client
    keys : sequence of str, optional
        Unique dask keys of the tasks (default: generated).
    progress : bool
        tqdm progress bar over completed tasks.
    desc : str
        Label of the progress bar.
    on_result : callable, optional
        ``on_result(client, n_done)`` after each completed task (monitoring, fault injection in tests).

    Raises
    ------
    StudyError
        Tasks failed; the message gives the count and the first error. Results of the others are
        already written by the tasks themselves.
    """
    from distributed import as_completed
    from distributed.scheduler import KilledWorker
    from tqdm import tqdm

    out: list = [None] * len(tasks)
    if not tasks:
        return out
    base = list(keys) if keys is not None else [f"{desc}-{i}" for i in range(len(tasks))]
    futures = {}
    for i, t in enumerate(tasks):
        futures[client.submit(fn, t, key=base[i], pure=False, retries=1)] = (i, 0)
    failed: list[tuple[int, BaseException]] = []
    bar = tqdm(total=len(tasks), desc=desc, unit="task", disable=not progress)
    done = 0
    ac = as_completed(list(futures))
    for fut in ac:
        i, attempt = futures.pop(fut)
        try:
            out[i] = fut.result()
        except KilledWorker as exc:
            if attempt >= MAX_RESUBMIT:
                failed.append((i, exc))
            else:
                log.warning("task %s lost with its worker; resubmitting", base[i])
                new = client.submit(fn, tasks[i], key=f"{base[i]}-r{attempt + 1}", pure=False, retries=1)
                futures[new] = (i, attempt + 1)
                ac.add(new)
                continue
        except Exception as exc:  # noqa: BLE001 (every task failure is reported together at the end)
            failed.append((i, exc))
        fut.release()
        done += 1
        bar.update()
        if on_result is not None:
            on_result(client, done)
    bar.close()
    if failed:
        i, exc = failed[0]
        text = " ".join(str(exc).split())
        raise StudyError(f"{len(failed)} of {len(tasks)} tasks failed; first ({base[i]}): {type(exc).__name__}: {text}")
    return out
