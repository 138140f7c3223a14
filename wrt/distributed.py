"""Runs independent tasks on a Dask distributed cluster and hands each result back the moment it arrives.

``run_tasks(fn, items, on_result=...)`` submits ``fn(item)`` for every item to the scheduler at ``address`` or,
without one, to a ``LocalCluster`` started here (one single-threaded worker process per CUDA GPU, else per CPU core)
and closed at the end. Results come back to this process in completion order and go to ``on_result`` at once, so
the caller writes each one as it arrives: a worker that dies loses only the task it was running, and the scheduler
reruns that task on another worker. A task asks ``worker_device()`` which Warp device is its own.

Tasks must be picklable top-level functions of an importable module, and every worker needs the same ``wrt``
installed. Warp compiles kernels once per worker process; after the first, it loads them from the on-disk kernel
cache that the workers of one machine share.
"""

from __future__ import annotations

import os

import numpy as np

from .errors import flag

DEVICE_ENV = "WRT_DEVICE"  # overrides worker_device(), e.g. "cuda:1", for workers started by hand
CONNECT_TIMEOUT = 30.0  # seconds to wait for the scheduler at an address
INSTALL_HINT = "pip install 'wrt[dask]'"


class DaskUnavailable(RuntimeError):
    """``dask.distributed`` is not installed, or the scheduler cannot be reached."""


def worker_device() -> str:
    """The Warp device of the calling task: ``"cuda:K"`` for the worker's own GPU, else ``"cpu"``.

    ``$WRT_DEVICE`` wins when set. Otherwise workers with integer names (a ``LocalCluster`` names them 0..N-1)
    take GPUs round robin, and any other worker takes ``cuda:0``, which is its own GPU under ``dask-cuda`` (one
    ``CUDA_VISIBLE_DEVICES`` per worker). Outside a worker this returns ``cuda:0`` or ``cpu``.
    """
    if os.environ.get(DEVICE_ENV):
        return os.environ[DEVICE_ENV]
    import warp as wp

    count = wp.get_cuda_device_count()
    if count == 0:
        return "cpu"
    try:
        from distributed import get_worker

        name = get_worker().name
    except (ImportError, ValueError):  # ValueError: not running inside a worker
        return "cuda:0"
    return f"cuda:{name % count}" if isinstance(name, int) else "cuda:0"


def default_workers() -> int:
    """One worker per CUDA GPU, else one per CPU core."""
    import warp as wp

    return wp.get_cuda_device_count() or os.cpu_count() or 1


def connect(address: str | None = None, n_workers: int | None = None, retries: int = 2):
    """A ``distributed.Client`` for ``address``, or for a new ``LocalCluster``; returns ``(client, cluster)``.

    ``cluster`` is the ``LocalCluster`` started here (close it after the client) or None. Raises
    ``DaskUnavailable`` naming the fix when dask is missing, or naming the address when nothing answers there.
    """
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError as e:
        raise DaskUnavailable(f"running on a Dask cluster needs dask.distributed: {INSTALL_HINT}") from e
    if address:
        try:
            return Client(address, timeout=CONNECT_TIMEOUT), None
        except ValueError as e:  # no address at all ('8786': missing port), refused at once: not 'cannot reach'
            raise ValueError(f"Dask scheduler address {address!r}: {e}; give one such as 'tcp://host:8786'") from None
        except (OSError, TimeoutError) as e:
            raise DaskUnavailable(
                f"cannot reach a Dask scheduler at {address!r} within {CONNECT_TIMEOUT:.0f} s ({type(e).__name__})"
            ) from e
    # The scheduler reads these when it starts. allowed-failures: how often a task may be on a worker that dies.
    # worker-saturation 1.0: a single-threaded worker holds only the task it runs, so a worker that dies takes
    # no queued task down with it (queued tasks would count a failure too, and could run out of retries).
    config = {"distributed.scheduler.allowed-failures": retries, "distributed.scheduler.worker-saturation": 1.0}
    with dask.config.set(config):
        cluster = LocalCluster(
            n_workers=n_workers or default_workers(),
            threads_per_worker=1,  # one task per process: Warp launches and device memory stay unshared
            processes=True,
            memory_limit=0,  # no per-worker cap: the nanny would kill a worker at 95% of RAM / n_workers
            env={"WRT_THREADS": "1"},  # a worker per core already: no trace thread pools on top
            dashboard_address=":0",
        )
    return Client(cluster), cluster


PARTIAL_TOPIC = "wrt-partial-results"  # the Dask event topic of send_partial()


def send_partial(value) -> None:
    """From inside a task of :func:`run_tasks`: hands ``value``, a finished part of the task's result (a bench row
    of a group), to the client at once, so that a Ctrl-C there, or the death of the worker, that cuts the task short
    keeps it (``on_partial``); the task's return value still carries the whole result. Does nothing outside a Dask
    worker."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # ValueError: not running inside a worker
        return
    import pickle

    # Pickled: a Dask event must be msgpack-serializable, and a row holds numpy numbers.
    # attempt: a worker the nanny restarts may have the address of the one that died, never its process id.
    worker.log_event(PARTIAL_TOPIC, {"key": worker.get_current_task(), "attempt": f"{worker.address} {os.getpid()}",
                                     "value": pickle.dumps(value)})


class _Partials:
    """The values each running task sent with :func:`send_partial`, by task key; those of the task's latest attempt
    only (a task rerun after its worker died sends its parts again)."""

    def __init__(self):
        self.by_key = {}

    def __call__(self, event) -> None:  # a Dask topic handler, called with (timestamp, message)
        import pickle

        message = event[1]
        attempt, values = self.by_key.get(message["key"], (None, []))
        if attempt != message["attempt"]:
            values = []
        self.by_key[message["key"]] = (message["attempt"], values + [pickle.loads(message["value"])])

    def of(self, key) -> list:
        return self.by_key.get(key, (None, []))[1]


def _started(client, futures: dict) -> list[int]:
    """The indices (the values of ``futures``) of the tasks a worker is running or has finished, in order; every
    one where the scheduler does not answer."""
    try:
        running = {key for keys in client.processing().values() for key in keys}
    except Exception:  # noqa: BLE001 - a scheduler gone (its workers stopped by the same Ctrl-C): say all may be
        return sorted(futures.values())
    return sorted(i for future, i in futures.items() if future.done() or future.key in running)


def run_tasks(
    fn,
    items,
    *,
    address: str | None = None,
    n_workers: int | None = None,
    on_result=None,
    on_error=None,
    on_interrupt=None,
    on_partial=None,
    retries: int = 2,
    timeout: float | None = None,
    progress: bool = True,
    desc: str = "tasks",
):
    """Runs ``fn(item)`` for every item on a Dask cluster and hands each result over as it arrives.

    Args:
        fn: picklable top-level function of one item; it runs in a worker process (see ``worker_device()``).
        items: picklable arguments, one task each.
        address: scheduler address such as ``tcp://host:8786``; None starts a ``LocalCluster`` for this call.
        n_workers: worker processes of the ``LocalCluster``; default ``default_workers()``. Ignored with ``address``.
        on_result: ``on_result(item, result)``, called in this process in completion order, as each task finishes.
        on_error: ``on_error(item, exception)`` for a task that raised, or whose workers kept dying; without it the
            first such exception is raised once every other task has finished and been handed to ``on_result``.
        on_interrupt: ``on_interrupt(items)`` at Ctrl-C, before the ``KeyboardInterrupt`` goes on: the items cut
            short, those whose tasks a worker was running (as the scheduler says; every task not handed over where it
            does not answer) or had finished and were not yet handed over (or being handed over).
        on_partial: ``on_partial(item, values)`` for each task cut short that had sent parts of its result with
            ``send_partial()`` (in the order sent; of its last attempt), so that they are kept: at Ctrl-C, before
            ``on_interrupt`` (not for a task whose result ``on_result`` was handling, which may have taken some of
            them already), and before ``on_error`` for a task that failed (its workers kept dying).
        retries: how often a task is rerun after its worker dies (a ``LocalCluster``'s ``allowed-failures``; a
            remote scheduler uses its own setting). Exceptions raised by ``fn`` are not retried.
        timeout: seconds for the whole run; ``TimeoutError`` after that. None: no limit.
        progress: show a tqdm bar.
        desc: label of the bar.

    Returns:
        The results in the order of ``items`` (None for a task handed to ``on_error``) when ``on_result`` is None;
        otherwise None, so that large results (images) are not all kept in memory.
    """
    from tqdm import tqdm

    progress = flag(progress, "progress")  # by its truth, "false" showed the bar
    if n_workers is not None and (isinstance(n_workers, bool) or not isinstance(n_workers, (int, np.integer))
                                  or n_workers < 1):  # 0 fell back to default_workers(), -1 failed in Dask's words
        raise ValueError(f"n_workers must be a positive integer or None, got {n_workers!r}")
    if address is not None and not isinstance(address, str):  # Dask's message named no argument
        raise TypeError(f"address must be a scheduler address str, such as 'tcp://host:8786', or None, got "
                        f"{type(address).__name__} {address!r}")
    items = list(items)
    client, cluster = connect(address, n_workers, retries)
    results = {} if on_result is None else None
    failed = []
    futures = {}  # future -> item index; none yet at a Ctrl-C while they are sent (on_interrupt then gets none)
    partials, handing_over = _Partials(), None
    if on_partial is not None:
        client.subscribe_topic(PARTIAL_TOPIC, partials)
    try:
        from distributed import as_completed

        # pure=False: equal items are still separate tasks, never merged or served from a cache.
        futures = {future: i for i, future in enumerate(client.map(fn, items, pure=False))}

        with tqdm(total=len(items), desc=desc, disable=not progress) as bar:
            for future in as_completed(futures, timeout=timeout):
                i = futures[future]
                try:
                    result = future.result()
                except Exception as e:  # noqa: BLE001 - the task's own error, or KilledWorker
                    if on_partial is not None and partials.of(future.key):
                        on_partial(items[i], partials.of(future.key))
                    if on_error is None:
                        failed.append(e)
                    else:
                        on_error(items[i], e)
                else:
                    if results is None:
                        handing_over = future
                        on_result(items[i], result)
                        handing_over = None
                    else:
                        results[i] = result
                del futures[future]  # handed over (kept until now: a Ctrl-C in on_result cut this item short)
                future.release()  # forget it: a result already here is never recomputed when a worker dies
                bar.update()
    except KeyboardInterrupt:
        if on_partial is not None:
            for future, i in sorted(futures.items(), key=lambda pair: pair[1]):
                if future is not handing_over and partials.of(future.key):
                    on_partial(items[i], partials.of(future.key))
        if on_interrupt is not None:
            on_interrupt([items[i] for i in _started(client, futures)])
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    if failed:
        raise failed[0]
    return None if results is None else [results.get(i) for i in range(len(items))]
