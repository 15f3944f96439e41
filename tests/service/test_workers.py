"""Render workers under supervision (real worker processes, real GL): deadlines kill and
replace the worker, a killed or broken worker is replaced, memory over budget recycles,
liveness follows probes."""

from __future__ import annotations

import asyncio
import os
import signal
import time
from concurrent.futures import ThreadPoolExecutor

import faults
import pytest

from fogbank.service import metrics

from fogbank.workers import worker
from fogbank.settings import Settings
from fogbank.workers.supervisor import DeadlineExceeded, QueueTimeout, Supervisor, WorkerError


def run(coro_fn, settings: Settings):
    """Start a supervisor, run `coro_fn(sup)`, stop it: on a thread of its own, since
    other tests (Playwright's sync API) may leave an event loop on this one."""
    async def main():
        sup = Supervisor(settings)
        await sup.start()
        try:
            return await coro_fn(sup)
        finally:
            await sup.stop()
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, main()).result()


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:   # a zombie is dead too
        return open(f"/proc/{pid}/stat").read().split()[2] != "Z"
    except OSError:
        return False


def test_a_job_past_its_deadline_kills_the_worker_and_others_go_on():
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        old = slot.pid
        kills = metrics.DEADLINE_KILLS.labels("interactive")._value.get()
        t0 = time.monotonic()
        with pytest.raises(DeadlineExceeded):
            await sup.call(slot, worker.sleep, 30.0, deadline=0.5)
        took = time.monotonic() - t0
        assert took < 5.0                                   # not the job's 30 s
        out = await sup.call(slot, worker.probe, deadline=30)
        assert out["ok"] is True
        assert out["pid"] != old                            # a fresh process
        assert not alive(old)
        assert metrics.DEADLINE_KILLS.labels("interactive")._value.get() == kills + 1
        # the batch worker was never touched
        assert (await sup.call(sup.batch.slots[0], worker.probe, deadline=30))["ok"] is True
    run(body, Settings())


def test_a_job_that_waits_too_long_is_abandoned():
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        busy = asyncio.ensure_future(sup.call(slot, worker.sleep, 3.0, deadline=30))
        await asyncio.sleep(0.3)
        t0 = time.monotonic()
        with pytest.raises(QueueTimeout):
            await sup.call(slot, worker.probe, deadline=0.2, queue_s=0.2)
        assert time.monotonic() - t0 < 1.5
        await busy
        assert slot.finished >= t0   # the sleep's end is noted as progress (stalled())
        assert (await sup.call(slot, worker.probe, deadline=30))["ok"] is True
    run(body, Settings())


def test_a_worker_killed_while_idle_is_replaced():
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        old = slot.pid
        os.kill(old, signal.SIGKILL)
        await asyncio.sleep(0.5)
        deadline = time.monotonic() + 20
        while True:   # the first call may report the loss; a later one succeeds
            try:
                out = await sup.call(slot, worker.probe, deadline=30)
                break
            except WorkerError:
                assert time.monotonic() < deadline
                await asyncio.sleep(0.2)
        assert out["ok"] is True and out["pid"] != old
    run(body, Settings())


def test_a_worker_over_its_memory_budget_is_recycled_between_jobs():
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        old = slot.pid
        out = await sup.call(slot, faults.allocate, 400, deadline=30)
        assert out["recycle"] is True and out["rss"] > 300 << 20
        fresh = await sup.call(slot, worker.probe, deadline=30)
        assert fresh["pid"] != old and fresh["rss"] < 300 << 20
        for _ in range(100):
            if not alive(old):
                break
            await asyncio.sleep(0.1)
        assert not alive(old)                                # the old one exited
    run(body, Settings(worker_memory_mb=300))


def test_liveness_fails_while_no_worker_answers_and_recovers():
    async def body(sup: Supervisor):
        assert sup.live()[0] is True
        pids = [s.pid for s in sup.slots()]
        for pid in pids:
            os.kill(pid, signal.SIGSTOP)      # hung: alive, but rendering nothing
        try:
            await asyncio.sleep(2.5)
            assert sup.live()[0] is False
        finally:
            for pid in pids:
                os.kill(pid, signal.SIGCONT)
        # back once a worker renders: the continued one, or its replacement if the stall
        # was found first (3 s without progress; a new worker warms up in about 7 s)
        for _ in range(300):
            if sup.live()[0]:
                break
            await asyncio.sleep(0.1)
        assert sup.live()[0] is True
    run(body, Settings(liveness_s=1.5, probe_interval_s=0.2, probe_deadline_s=60))


# a new worker's allowance to start: its warm-up (meshes, programs) takes about 7 s here
START_S = 15.0


def test_a_stuck_worker_is_replaced_when_its_probes_never_start():
    """A worker past its allowance to start that starts no job (stopped) is replaced, and
    its replacement, warming up, is given its own allowance, not replaced in turn (with 1 s,
    a warm-up of 7 s was taken for stuck again and again: the pool broke under the call)."""
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        await sup.call(slot, worker.probe, deadline=30, queue_s=60)   # up and warm
        old = slot.pid
        await asyncio.sleep(max(0.0, slot.started + START_S - time.monotonic()))
        os.kill(old, signal.SIGSTOP)
        await asyncio.sleep(4.0)       # nothing starts for 1.5 s: the stuck worker is replaced
        out = await sup.call(slot, worker.probe, deadline=30, queue_s=START_S)
        assert out["pid"] != old
        assert sup.live()[0] is True
        for _ in range(100):           # and the stopped one is killed, not left behind
            if not alive(old):
                break
            await asyncio.sleep(0.1)
        assert alive(old) is False
    run(body, Settings(probe_interval_s=0.2, probe_deadline_s=0.5, liveness_s=1.0, worker_start_s=START_S))


def test_a_stream_frame_says_whether_the_worker_held_its_scene_pass():
    """worker.frame's `scene_reused` (stream/session.py learns from it that the worker's
    cache let its scene pass go): a session's first frame draws its scene pass, its next
    with the camera still finds it, a new camera draws it again, and after the worker
    drops the session's caches the same camera draws it again too. A view that teaches
    says nothing."""
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    look = StillParams.model_validate({**preset_dict("default"), "width": 160, "height": 90})
    turned = look.model_copy(update={"camera": look.camera.model_copy(update={"yaw": look.camera.yaw + 10})})

    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]

        async def reused(still, show="shaded"):
            out = await sup.call(slot, worker.frame, still, "s", True, 80, show, 0, False, deadline=30)
            return out["scene_reused"]
        got = [await reused(look), await reused(look), await reused(turned), await reused(turned)]
        await sup.call(slot, worker.drop_slot, "s", deadline=30)
        got += [await reused(turned), await reused(turned, "transmittance")]
        return got
    assert run(body, Settings()) == [False, True, False, True, False, None]


def test_workers_bake_with_one_blas_thread():
    """The noise bake's tensor contractions run on BLAS; each worker gets one BLAS thread
    (a thread per core in every worker would take the cores of the others' frames)."""
    async def body(sup: Supervisor):
        return [(await sup.call(slot, worker.probe, deadline=30))["blas_threads"]
                for slot in (sup.interactive.slots[0], sup.batch.slots[0])]
    assert run(body, Settings()) == ["1", "1"]


def test_a_frame_that_drew_the_full_shadow_map_did_work_once():
    """worker.frame's `once` for the sun: a full frame for a sun the worker's full shadow
    map was not drawn for draws it (134-139 ms here whatever the frame's size), paid once,
    so not the look's cost (stream/session.py calibrates nothing on it); the next frame
    with that sun does not. A preview (draft) with a new sun draws the preview map, which
    a dragged sun pays every frame: its cost, not once."""
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    look = StillParams.model_validate({**preset_dict("default"), "width": 160, "height": 90})

    def sun(az):
        return look.model_copy(update={"sun": look.sun.model_copy(update={"azimuth": az})})

    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]

        async def once(still, draft):
            out = await sup.call(slot, worker.frame, still, "s", not draft, 80, "shaded", 0, False, draft,
                                 deadline=30)
            return out["once"]
        await once(sun(50.0), False)   # compiles what a first frame compiles
        await once(sun(51.0), True)
        return [await once(sun(40.0), False), await once(sun(40.0), False), await once(sun(41.0), True),
                await once(sun(42.0), True)]
    assert run(body, Settings()) == [True, False, False, False]


def test_a_deadline_tells_a_stalled_worker_from_a_busy_one():
    """Issue 33 finding 2: a job past its deadline on a worker that used no CPU (asleep,
    stopped) is the server's fault (DeadlineExceeded.stalled); one that kept a core busy is
    the job's. Measured by the worker's CPU time from /proc, sampled while it has jobs."""
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        with pytest.raises(DeadlineExceeded) as idle:
            await sup.call(slot, worker.sleep, 30.0, deadline=3.0)
        await sup.call(slot, worker.probe, deadline=30, queue_s=60)   # the replacement is up
        with pytest.raises(DeadlineExceeded) as busy:
            await sup.call(slot, faults.spin, 30.0, deadline=3.0)
        return idle.value, busy.value
    idle, busy = run(body, Settings(probe_interval_s=0.5))
    print(f"\ncores used: asleep {idle.cpu_share}, spinning {busy.cpu_share}")
    assert idle.stalled is True and idle.cpu_share < 0.2
    assert "stalled" in str(idle) and idle.retry_after == 2
    assert busy.stalled is False and busy.cpu_share > 0.5
    assert "took over 3 s" in str(busy) and busy.retry_after == 5


def test_a_stopped_worker_with_jobs_waiting_is_replaced_and_its_callers_told_at_once():
    """A worker stopped between jobs takes none: the callers waited the queue's 30 s (a
    stream saw no frame for 34 s). Now it is replaced once it has used no CPU for
    STALL_WINDOW_S with jobs waiting, and the waiting callers get a WorkerError then."""
    async def body(sup: Supervisor):
        slot = sup.interactive.slots[0]
        await sup.call(slot, worker.probe, deadline=30, queue_s=60)
        old = slot.pid
        os.kill(old, signal.SIGSTOP)
        try:
            t0 = time.monotonic()
            with pytest.raises(WorkerError) as lost:
                await sup.call(slot, worker.probe, deadline=30)
            waited = time.monotonic() - t0
            out = await sup.call(slot, worker.probe, deadline=30, queue_s=60)
        finally:
            try:
                os.kill(old, signal.SIGCONT)
            except ProcessLookupError:
                pass
        return waited, str(lost.value), old, out["pid"]
    waited, msg, old, new = run(body, Settings(probe_interval_s=0.5))
    print(f"\nthe waiting call was told after {waited:.1f} s: {msg}")
    assert waited < 8.0            # was the queue's 30 s
    assert "stalled and was replaced" in msg
    assert new != old
