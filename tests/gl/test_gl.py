"""The GL context (render/gl.py): llvmpipe's raster threads, counted by name in the
process that made the context (a fresh one each time: llvmpipe reads LP_NUM_THREADS when
the first context is made)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from fogbank.render.gl import raster_threads

PROBE = """
import json, os
from fogbank.render.gl import create_context
ctx = create_context({threads})
names = [open(f"/proc/self/task/{{t}}/comm").read().strip() for t in os.listdir("/proc/self/task")]
print(json.dumps({{"renderer": ctx.info["GL_RENDERER"], "raster": sum(n.startswith("llvmpipe") for n in names)}}))
"""


def _probe(threads: str, env: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", PROBE.format(threads=threads)], capture_output=True,
                         text=True, timeout=60, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_raster_threads_are_one_more_than_a_workers_share_of_the_cores():
    cores = len(os.sched_getaffinity(0))
    assert raster_threads(1) == cores + 1
    assert raster_threads(2) == max(1, cores // 2) + 1
    assert raster_threads(10 * cores) == 2


def test_llvmpipe_runs_the_threads_asked_for_and_lp_num_threads_wins():
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    got = _probe("", env)
    if "llvmpipe" not in got["renderer"]:
        pytest.skip("a GPU has no raster threads of its own to count")
    assert got["raster"] == raster_threads()
    assert _probe("'egl', None, 5", env)["raster"] == 5
    assert _probe("'egl', None, 5", {**env, "LP_NUM_THREADS": "3"})["raster"] == 3


def test_a_context_without_the_packing_extension_is_refused_by_name(renderer):
    """GL 3.3 without GL_ARB_shading_language_packing (core from 4.2) cannot compile the
    held composite: create_context says so at start. This context (4.5) passes; one that
    reports 3.3 and lacks the extension is refused, naming it."""
    from types import SimpleNamespace

    from fogbank.render.gl import check_extensions
    check_extensions(renderer.ctx)
    old = SimpleNamespace(version_code=330, extensions={"GL_ARB_texture_gather"}, info={"GL_RENDERER": "old"})
    with pytest.raises(RuntimeError, match="GL_ARB_shading_language_packing"):
        check_extensions(old)
    check_extensions(SimpleNamespace(version_code=330, extensions={"GL_ARB_shading_language_packing"}, info={}))
