"""The soak, 60 seconds of it, in churn mode: 8 streaming clients each changing look and
view size every second; every client keeps receiving frames, no errors, the memory of
the whole process tree (server and render workers) grows no more than 10% after warm-up,
no error in the server's log. (docs/soak-churn.json is a 10-minute run of the same.)"""

from __future__ import annotations

import subprocess
import sys


def test_soak_60_seconds(tmp_path):
    out = tmp_path / "soak.json"
    r = subprocess.run([sys.executable, "-m", "fogbank.cli", "soak", "--clients", "8", "--seconds", "60",
                        "--churn", "--out", str(out)], capture_output=True, text=True, timeout=240)
    print("\n" + r.stdout)
    assert r.returncode == 0, r.stdout + r.stderr[-3000:]
    assert "PASS" in r.stdout
