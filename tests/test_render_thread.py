"""The render thread: a failing job fails only its own future; a GL failure rebuilds the
renderer; the thread keeps serving."""

from __future__ import annotations

import threading

import pytest

from fogbank.params import StillParams
from fogbank.render_thread import RenderThread


@pytest.fixture(scope="module")
def rt():
    t = RenderThread("egl")
    t.wait_ready()
    yield t
    t.stop()


def test_jobs_run_on_the_one_thread(rt):
    names = {rt.submit(lambda r: threading.current_thread().name).result(30) for _ in range(5)}
    assert names == {"fogbank-render"}


def test_a_failing_job_fails_alone(rt):
    def boom(r):
        raise ValueError("bad job")
    f = rt.submit(boom)
    with pytest.raises(ValueError, match="bad job"):
        f.result(30)
    img = rt.submit(lambda r: r.render(StillParams(width=32, height=32))).result(60)
    assert img.shape == (32, 32, 3)


def test_gl_failure_rebuilds_the_renderer(rt):
    before = rt.generation

    def lose_context(r):
        r.ctx.release()                       # what a lost context looks like to the next call
        r.ctx.buffer(b"1234")
    with pytest.raises(Exception):
        rt.submit(lose_context).result(30)
    rt.submit(lambda r: None).result(30)
    assert rt.generation == before + 1
    img = rt.submit(lambda r: r.render(StillParams(width=48, height=32))).result(60)
    assert img.shape == (32, 48, 3)


def test_gl_error_flag_fails_the_job_and_recovers(rt):
    def make_gl_error(r):
        r.ctx.enable_direct(0x1234)           # not a capability: leaves GL_INVALID_ENUM
        return "done"
    with pytest.raises(RuntimeError, match="GL error"):
        rt.submit(make_gl_error).result(30)
    assert rt.submit(lambda r: r.render(StillParams(width=16, height=16))).result(60).shape == (16, 16, 3)
