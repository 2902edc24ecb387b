"""Where many tasks run (``--backend``, ``--workers``): in this process, a pool of spawned processes, or
Ray; each task's result as it finishes. A job that sends work in rounds (a tune's generations) holds one
session of workers across them. Workers are capped at the tasks left and the CPUs this process may use."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
from collections.abc import Callable, Iterator
from typing import Any

from bipedsim.errors import BipedsimError, ConfigError

#: What a job asked to run on Ray says when the ``ray`` package is not installed.
RAY_MISSING = "the Ray backend needs the ray package: pip install 'bipedsim[ray]'"


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local(tasks: list, workers: int, fn: Callable[[Any], Any]) -> Iterator[Any]:
    """``fn`` of every task, as each finishes: in this process (1 worker) or a pool of ``workers``."""
    if workers <= 1:
        for t in tasks:
            yield fn(t)
        return
    ctx = mp.get_context("spawn")  # a clean interpreter per worker: no inherited MuJoCo or GL state
    # workers leave Ctrl-C to the parent, which stops the pool (no traceback from every worker)
    with ctx.Pool(workers, initializer=_ignore_sigint) as pool:
        yield from pool.imap_unordered(fn, tasks)


def check_backend(backend: str) -> None:
    """Refuse, before anything is written, a backend that is not known or cannot run here: Ray when the
    ``ray`` package is not installed (:class:`ConfigError` naming ``--backend`` and the fix)."""
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; choose {', '.join(BACKENDS)}", key="--backend")
    if backend == "ray":
        try:
            import ray  # noqa: F401 - imported only to learn whether it can be
        except ImportError:
            raise ConfigError(RAY_MISSING, key="--backend") from None


@contextlib.contextmanager
def ray_session(workers: int) -> Iterator[Any]:
    """The ``ray`` module, initialised for ``workers`` CPUs unless it already is (and then shut down
    on leaving); :class:`BipedsimError` when Ray is not installed. A long job that sends work to Ray
    in several rounds holds one session around them all."""
    try:
        import ray
    except ImportError:
        raise BipedsimError(RAY_MISSING) from None
    started = False
    if not ray.is_initialized():
        ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False,
                 ignore_reinit_error=True)
        started = True
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def _ray(tasks: list, workers: int, fn: Callable[[Any], Any]) -> Iterator[Any]:
    with ray_session(workers) as ray:
        remote = ray.remote(fn)
        pending = [remote.remote(t) for t in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])


@contextlib.contextmanager
def backend_session(backend: str, workers: int) -> Iterator[Callable[[list, Callable[[Any], Any]], Iterator[Any]]]:
    """``run(tasks, fn)`` -> ``fn``'s result of each task as it finishes, for a job that sends work in
    several rounds (a tune's generations): the workers start once and keep what they have built (each
    process's cached bodies and clips) from one round to the next -- one pool of ``workers`` spawned
    processes (local; in this process for 1), or one Ray session."""
    if backend == "ray":
        with ray_session(workers):
            yield lambda tasks, fn: _ray(tasks, workers, fn)
    elif workers <= 1:
        yield lambda tasks, fn: (fn(t) for t in tasks)
    else:
        with mp.get_context("spawn").Pool(workers, initializer=_ignore_sigint) as pool:
            yield lambda tasks, fn: pool.imap_unordered(fn, tasks)


#: backend name -> (tasks, workers, fn) -> fn's result of each task, in the order they finish
BACKENDS: dict[str, Callable[..., Iterator[dict[str, Any]]]] = {"local": _local, "ray": _ray}


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the system has one, e.g. in a container)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def worker_count(requested: int, rollouts: int, cpus: int | None = None) -> tuple[int, str | None]:
    """Workers to start: ``requested`` capped at the rollouts left and the CPUs (more only adds
    start-up: each worker imports MuJoCo and builds the body, seconds each, and they share the CPUs),
    and a one-line note when capped. ``requested`` >= 1 (:func:`run_sweep` checks it)."""
    cpus = usable_cpus() if cpus is None else cpus
    n = max(1, min(requested, rollouts, cpus))
    if n == requested or rollouts == 0:
        return requested, None
    why = f"{rollouts} rollout(s) left" if rollouts <= cpus else f"{cpus} CPU(s)"
    return n, f"using {n} worker(s), not {requested}: {why}"
