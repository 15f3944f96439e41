"""A fogbank server as a child process on 127.0.0.1 (for the bench and soak commands):
a free port, its log in a file, its memory from /proc, stopped by its PID."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from fogbank.workers import proctree


class ChildServer:
    def __init__(self, timeout: float = 60.0, env: dict | None = None):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = tempfile.NamedTemporaryFile(prefix="fogbank-child-", suffix=".log", delete=False)
        # every load client comes from 127.0.0.1: lift the per-address session cap
        env = {**os.environ, "FOGBANK_MAX_SESSIONS_PER_CLIENT": "1000", **(env or {})}
        self.proc = subprocess.Popen([sys.executable, "-m", "fogbank.cli", "serve", "--host", "127.0.0.1",
                                      "--port", str(self.port)], stdout=self.log, stderr=subprocess.STDOUT, env=env)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(self.url + "/healthz", timeout=1)
                return
            except OSError:
                time.sleep(0.2)
        self.stop()
        raise RuntimeError(f"the server did not start; its log: {self.log.name}")

    def rss_mb(self) -> float:
        """Resident memory of the server and its render workers, MB."""
        return proctree.tree_rss_bytes(self.proc.pid) / 2**20

    def log_text(self) -> str:
        return Path(self.log.name).read_text(errors="replace")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(30)
