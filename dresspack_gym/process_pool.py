"""Worker processes that leave Ctrl-C to the command that started them: the one way this package starts a pool."""

from __future__ import annotations

import multiprocessing
import multiprocessing.pool
import multiprocessing.resource_tracker
import signal
import threading
from collections.abc import Callable


def spawn_pool(processes: int, initializer: Callable | None = None, initargs: tuple = ()) -> multiprocessing.pool.Pool:
    """A ``spawn`` pool (no MuJoCo, OMPL, GL or torch state inherited) of ``processes`` workers that never answer
    Ctrl-C themselves: the command answers it (one line, then it ends the pool).

    While the pool starts, Ctrl-C is blocked in this thread, and a blocked signal stays blocked across fork and exec,
    so a worker that is still importing cannot die of it with a traceback; each worker then ignores it (a pending one
    is discarded) before its ``initializer`` runs. Here, a Ctrl-C pressed meanwhile is held, not lost, and reaches
    this process's handler as soon as the pool is up."""
    # the resource tracker, started with the first pool, unblocks Ctrl-C in this thread after it starts: started
    # first, it leaves the block below alone
    multiprocessing.resource_tracker.ensure_running()
    on_main = threading.current_thread() is threading.main_thread()
    pressed: list[int] = []
    handler = signal.signal(signal.SIGINT, lambda signum, _: pressed.append(signum)) if on_main else None
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        pool = multiprocessing.get_context("spawn").Pool(processes, initializer=_start_worker,
                                                           initargs=(initializer, initargs))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a Ctrl-C held until now is delivered here
        if on_main:
            signal.signal(signal.SIGINT, handler)
    if pressed:
        try:
            signal.raise_signal(signal.SIGINT)  # to the handler it was meant for, now that the pool can be ended
        except BaseException:
            pool.terminate()
            raise
    return pool


def _start_worker(initializer: Callable | None, initargs: tuple) -> None:
    """Ignore Ctrl-C (the parent's), unblock it, then the pool's own initializer."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if initializer is not None:
        initializer(*initargs)
