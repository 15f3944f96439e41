"""The supervisor's reading of a worker's progress (workers/supervisor.py cpu_stat): time
run or waited for a core, summed over its threads, and whether it is stopped."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from fogbank.workers.supervisor import cpu_stat

pytestmark = pytest.mark.unit


def _progress(pid: int, seconds: float) -> tuple[float, bool]:
    a = cpu_stat(pid)
    time.sleep(seconds)
    b = cpu_stat(pid)
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
        assert cpu_stat(None) is None and cpu_stat(2 ** 22 + 7) is None
    finally:
        for p in (busy, idle):
            os.kill(p.pid, signal.SIGKILL)
            p.wait(10)
