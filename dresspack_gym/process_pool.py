"""Worker processes that leave Ctrl-C to the command that started them: the one way this package starts a pool."""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.pool
import multiprocessing.resource_tracker
import os
import signal
import sys
import threading
from collections.abc import Callable

_PR_SET_PDEATHSIG = 1  # Linux prctl: the signal a process gets when the thread that started it ends


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
                                                           initargs=(os.getpid(), initializer, initargs))
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


def _start_worker(parent: int, initializer: Callable | None, initargs: tuple) -> None:
    """Ignore Ctrl-C (the parent's), unblock it, end with the parent, then the pool's own initializer."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    _end_with(parent)
    if initializer is not None:
        initializer(*initargs)


def _end_with(parent: int) -> None:
    """On Linux, this worker is terminated when the process that started it ends, however it ends: killed outright
    (SIGKILL, SIGTERM: no terminate()), it would leave a busy worker to finish its task (a leg, a map row) first."""
    if not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
        return  # not available here: the pool's own terminate() still ends the worker
    if os.getppid() != parent:  # the parent ended before the request was made
        os._exit(1)
