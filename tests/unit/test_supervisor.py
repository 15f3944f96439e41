"""The supervisor's reading of a worker's progress (workers/supervisor.py Progress): time
run or waited for a core, summed over its threads, and whether it is stopped."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from fogbank.workers.supervisor import Progress, thread_times

pytestmark = pytest.mark.unit


def _progress(pid: int, seconds: float) -> tuple[float, bool]:
    p = Progress(pid)
    a = p.read()
    time.sleep(seconds)
    b = p.read()
    return (b[0] - a[0]) / seconds, b[1]


def test_a_busy_process_progresses_and_a_stopped_one_does_not():
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    idle = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        time.sleep(0.3)
        share, stopped = _progress(busy.pid, 1.0)
        assert share > 0.5 and stopped is False          # run, or runnable and waiting: progress
        share, stopped = _progress(idle.pid, 1.0)
        assert share < 0.05 and stopped is False         # asleep: no progress, not stopped
        os.kill(busy.pid, signal.SIGSTOP)
        time.sleep(0.2)
        share, stopped = _progress(busy.pid, 1.0)
        assert share < 0.05 and stopped is True
        assert Progress(None).read() is None and Progress(2 ** 22 + 7).read() is None
    finally:
        for p in (busy, idle):
            os.kill(p.pid, signal.SIGKILL)
            p.wait(10)


# a thread spins for 1.5 s and ends; the main thread sleeps on
ENDING_THREAD = """
import threading, time
def spin():
    end = time.monotonic() + 1.5
    while time.monotonic() < end:
        pass
threading.Thread(target=spin).start()
time.sleep(60)
"""


def test_a_thread_that_ends_does_not_take_back_its_progress():
    """/proc lists live threads only: summed over those, the count fell by the ended
    thread's time (a worker read -2.49 cores and was called stalled, issue 33)."""
    proc = subprocess.Popen([sys.executable, "-c", ENDING_THREAD])
    try:
        p = Progress(proc.pid)
        time.sleep(0.3)
        readings = []
        for _ in range(15):   # through the thread's end, 0.2 s apart
            readings.append(p.read()[0])
            time.sleep(0.2)
        live_sum = sum(secs for secs, _ in thread_times(proc.pid).values())
        assert readings[-1] - readings[0] > 0.7        # the thread's run is counted after it ended
        assert live_sum < 0.5                          # what a sum over live threads says now
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)


def _slot_with_flat_cpu(now: float, busy_for: float, finished_ago: float | None):
    """A slot whose worker has had jobs in flight for `busy_for` s and used no CPU, sampled
    each second, a job of which finished `finished_ago` s ago (None: none did)."""
    from fogbank.workers.supervisor import Slot
    slot = Slot(lane="interactive", index=0, pool=None)
    slot.busy_since = now - busy_for
    slot.finished = 0.0 if finished_ago is None else now - finished_ago
    for k in range(6):
        slot.cpu.append((now - 5 + k, 10.0, False))   # CPU seconds flat: no progress
    return slot


def test_a_job_that_just_finished_is_progress_not_a_stall():
    """CI saw a worker that had run a 3 s sleep replaced as stalled in the moment between the
    sleep's end and pebble marking the next queued job as running: the window of no
    progress had begun with the sleep. A finished job restarts it."""
    from fogbank.workers.supervisor import STALL_WINDOW_S, Supervisor
    sup = object.__new__(Supervisor)
    sup.info = {"renderer": "llvmpipe (LLVM 15.0.7, 256 bits)"}
    now = 1000.0
    assert sup.stalled(_slot_with_flat_cpu(now, 4.0, None), now) is True             # the control
    assert sup.stalled(_slot_with_flat_cpu(now, 4.0, 0.2), now) is False
    assert sup.stalled(_slot_with_flat_cpu(now, 4.0, STALL_WINDOW_S - 0.5), now) is False
    # nothing for a whole window after the job finished: stalled again
    assert sup.stalled(_slot_with_flat_cpu(now, 9.0, STALL_WINDOW_S + 0.5), now) is True


def test_a_cancelled_job_is_no_progress():
    """A job's end is noted as progress from its future's done-callback, but not a job a
    caller cancelled: callers giving up on a stopped worker's queue would otherwise restart
    its window of no progress again and again."""
    from concurrent.futures import Future

    from fogbank.workers.supervisor import Slot
    slot = Slot(lane="interactive", index=0, pool=None)
    cancelled = Future()
    cancelled.add_done_callback(slot.note_finished)
    assert cancelled.cancel() is True
    assert slot.finished == 0.0
    done = Future()
    done.add_done_callback(slot.note_finished)
    done.set_result({"ok": True})
    assert slot.finished > 0.0
    failed = Future()
    slot.finished = 0.0
    failed.add_done_callback(slot.note_finished)
    failed.set_exception(RuntimeError("the job raised"))
    assert slot.finished > 0.0
