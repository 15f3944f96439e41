"""The soak, 60 seconds of it: 8 streaming clients; every client keeps receiving frames,
no errors, memory after warm-up grows no more than 10%, no error in the server's log."""

from __future__ import annotations

import subprocess
import sys


def test_soak_60_seconds(tmp_path):
    out = tmp_path / "soak.json"
    r = subprocess.run([sys.executable, "-m", "fogbank.cli", "soak", "--clients", "8", "--seconds", "60",
                        "--out", str(out)], capture_output=True, text=True, timeout=240)
    print("\n" + r.stdout)
    assert r.returncode == 0, r.stdout + r.stderr[-3000:]
    assert "PASS" in r.stdout
