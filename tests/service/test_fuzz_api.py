"""schemathesis against /openapi.json of a real server: every check, positive data
acceptance included, a fixed seed. The document describes the look (the POST body and
transmittance params reference the params model; the GET still declares its query
parameters), so schemathesis exercises the params: no 5xx, no undocumented status, no
schema-violating input accepted, and every schema-valid input that keeps the documented
rules accepted (see fuzz_hooks.py)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from servers import Server

HOOKS = "fuzz_hooks"


def test_schemathesis_all_checks_fixed_seed(tmp_path):
    # no cost refusals in this run: the budgets are tested in test_limits
    srv = Server(env={"FOGBANK_STILL_BUDGET_S": "3600", "FOGBANK_STILL_MEMORY_MB": "4096"}).start()
    try:
        st = Path(sys.executable).parent / "schemathesis"
        env = {**os.environ, "SCHEMATHESIS_HOOKS": HOOKS,
               "PYTHONPATH": str(Path(__file__).parents[1]) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        # a negative case may also be refused for its size before it is parsed (413: a
        # body over the server's limit; the limits are tested in test_limits)
        config = tmp_path / "schemathesis.toml"
        config.write_text('[checks.negative_data_rejection]\n'
                          'expected-statuses = ["400", "413", "414", "422", "431"]\n')
        r = subprocess.run([str(st), "--config-file", str(config), "run", srv.url + "/openapi.json",
                            "--checks", "all", "--seed", "42",
                            "--max-examples", "25", "--no-color",
                            "--report-dir", str(tmp_path)],
                           capture_output=True, text=True, timeout=600, env=env, cwd=tmp_path)
    finally:
        srv.stop()
    out = r.stdout + r.stderr
    m = re.search(r"(\d+) generated, (\d+) passed", out)
    assert r.returncode == 0, out[-6000:]
    assert m and m.group(1) == m.group(2) and int(m.group(1)) >= 100, out[-2000:]
    print(f"\nschemathesis: {m.group(1)} cases generated, {m.group(2)} passed")


def test_the_hooks_filter_drops_a_line_potential_without_a_direction():
    """Issue 33 finding 9: the filter called np.hypot with the direction's three values,
    got a TypeError, took the look for invalid anyway and kept the cases it meant to drop."""
    from fuzz_hooks import _look_ok
    line = {"kind": "potential", "shape": "line"}
    assert _look_ok({"layers": [{**line, "direction": [0.0, 0.0, 0.0]}]}) is False
    assert _look_ok({"layers": [{**line, "direction": [0.0, 0.0, 1e-9]}]}) is False
    assert _look_ok({"layers": [{**line, "direction": [0.0, 0.6, 0.8]}]}) is True
