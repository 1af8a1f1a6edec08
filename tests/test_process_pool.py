"""spawn_pool: workers never answer Ctrl-C, and a Ctrl-C pressed while the pool starts is held for the command."""

from __future__ import annotations

import multiprocessing.pool
import os
import signal
import subprocess
import sys
import time

import pytest

from dresspack_gym.process_pool import spawn_pool


def _sigint_state(_=None) -> tuple[bool, bool]:
    """(SIGINT ignored, SIGINT blocked) in this process, from the kernel's own account."""
    fields = dict(line.split(":\t") for line in open(f"/proc/{os.getpid()}/status").read().splitlines()
                  if line.startswith(("SigIgn", "SigBlk")))
    bit = 1 << (signal.SIGINT - 1)
    return bool(int(fields["SigIgn"], 16) & bit), bool(int(fields["SigBlk"], 16) & bit)


def test_workers_ignore_ctrl_c_and_the_caller_keeps_it():
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with spawn_pool(2) as pool:
            states = pool.map(_sigint_state, range(4))
        assert states == [(True, False)] * 4
        assert _sigint_state() == (False, False)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, handler)


def test_a_ctrl_c_while_the_pool_starts_is_raised_once_it_is_up_and_the_pool_ended(monkeypatch):
    started: list[multiprocessing.pool.Pool] = []
    repopulate = multiprocessing.pool.Pool._repopulate_pool

    def pressed_meanwhile(self):
        started.append(self)
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C lands while the workers are being started
        return repopulate(self)

    monkeypatch.setattr(multiprocessing.pool.Pool, "_repopulate_pool", pressed_meanwhile)
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            spawn_pool(2)
    finally:
        signal.signal(signal.SIGINT, handler)
    (pool,) = started
    pool.join()
    assert all(not p.is_alive() for p in pool._pool)


_BOOTING = """
import os, signal, sys, time
from dresspack_gym.process_pool import spawn_pool

def pid(_):
    return os.getpid()

if __name__ == "__main__":
    pressed = []
    signal.signal(signal.SIGINT, lambda *_: pressed.append(1))
    pool = spawn_pool(2, time.sleep, (0.5,))
    first = sorted(p.pid for p in pool._pool)
    os.killpg(0, signal.SIGINT)  # Ctrl-C to the whole group while the workers still import
    time.sleep(3)
    served = set(pool.map(pid, range(8), chunksize=1))
    print(pressed == [1], served <= set(first) and sorted(p.pid for p in pool._pool) == first)
    pool.terminate()
"""


def test_a_ctrl_c_to_the_group_while_workers_import_ends_none_of_them(tmp_path):
    script = tmp_path / "booting.py"
    script.write_text(_BOOTING)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120,
                          start_new_session=True)
    assert done.stdout.split() == ["True", "True"], done.stdout + done.stderr
    assert "KeyboardInterrupt" not in done.stderr, done.stderr


_KILLED = """
import sys, time
from dresspack_gym.process_pool import spawn_pool

if __name__ == "__main__":
    pool = spawn_pool(2)
    pool.map(abs, range(4))  # the workers are up
    pool.map_async(time.sleep, [100, 100], chunksize=1)  # and busy (an idle one ends at its pipe's end)
    time.sleep(1)
    print(*(p.pid for p in pool._pool), flush=True)
    time.sleep(120)
"""


def _alive(pid: int) -> bool:
    try:
        state = next(line for line in open(f"/proc/{pid}/status") if line.startswith("State:"))
    except (OSError, StopIteration):
        return False
    return "Z" not in state.split()[1]  # a zombie has ended


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's")
def test_busy_workers_end_when_their_command_is_killed_outright(tmp_path):
    script = tmp_path / "killed.py"
    script.write_text(_KILLED)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        workers = [int(pid) for pid in proc.stdout.readline().split()]
        assert len(workers) == 2 and all(_alive(pid) for pid in workers)
        proc.kill()  # SIGKILL: no handler, no atexit, no pool terminate()
        proc.wait()
        deadline = time.time() + 20
        while time.time() < deadline and any(_alive(pid) for pid in workers):
            time.sleep(0.1)
        assert not any(_alive(pid) for pid in workers)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
