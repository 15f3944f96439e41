"""The web process's side of the render workers: lanes of supervised worker processes,
deadlines, probes, memory recycling and their metrics.

GL never runs in the web process. Each worker is a process with its own EGL context
(worker.py), run by a pebble ProcessPool of one worker: pebble starts it, restarts it
when it dies, and kills it when a job passes its deadline or is cancelled (killing the
process is the only sure way to stop a GL call). One pool per worker, rather than one
pool of N, so that a streaming session keeps its worker (and its cached scene pass).

Two lanes:
- interactive: stream frames, probes and stills estimated to be cheap;
- batch: costly stills and transmittance requests, at a lower CPU priority (nice), so
  a heavy still neither blocks a small one nor starves the streams.
With `batch_workers = 0` everything runs on the interactive lane.

The event loop only awaits futures: it never waits on GL.
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import threading
import time
from collections import deque
from concurrent.futures import CancelledError as FutureCancelled
from concurrent.futures.process import BrokenProcessPool
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Callable

from pebble import ProcessExpired, ProcessPool

from fogbank.service import metrics

from fogbank.workers import proctree

from fogbank.workers import worker

log = logging.getLogger("fogbank.workers")

# A worker with jobs whose threads neither ran nor waited for a core for more than this
# share of one over STALL_WINDOW_S makes no progress: it is stalled (stopped, hung), not
# busy. Its progress is its threads' CPU time plus their time runnable in the run queue
# (/proc/PID/task/*/schedstat, Progress), so that a worker starved of cores (a niced batch worker
# beside the streams' raster threads gets ~0.2 cores) is busy, not stalled. With llvmpipe a
# render is CPU work; on a GPU a worker may sleep in its driver while the GPU draws, so
# there only a stopped worker (every thread in state T) is stalled, and a hang is left to
# the job's deadline.
STALL_CPU_SHARE = 0.2
STALL_WINDOW_S = 3.0


def thread_times(pid: int | None) -> dict[int, tuple[float, bool]] | None:
    """Each live thread of process `pid`: (the seconds it has run or waited runnable for a
    core; whether it is stopped, state T or t), from /proc; None where there is no such
    process, no /proc, or no schedstat (CONFIG_SCHED_INFO off: it tells nothing, which is
    not "no progress")."""
    if not pid:
        return None
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return None
    out = {}
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/schedstat", "rb") as f:
                on_cpu, waiting = f.read().split()[:2]
            with open(f"/proc/{pid}/task/{tid}/stat", "rb") as f:
                state = f.read().rsplit(b")", 1)[1].split()[0]
        except (OSError, IndexError, ValueError):
            continue   # a thread that ended meanwhile
        out[int(tid)] = ((int(on_cpu) + int(waiting)) / 1e9, state in (b"T", b"t"))
    return out or None


class Progress:
    """One worker process's progress as a count that never goes back: the time each thread
    it has had ran or waited for a core, summed. /proc lists live threads only, and a
    thread that ends takes its time with it: a sum over the live ones fell by seconds
    while a still rendered (a job past its deadline read -2.49 cores, "stalled", and was
    answered as the server's fault). Each thread adds what it gained since it was last
    seen; one that ended loses only its time since then."""

    def __init__(self, pid: int | None):
        self.pid = pid
        self.seen: dict[int, float] = {}
        self.total = 0.0

    def read(self) -> tuple[float, bool] | None:
        """(the count in seconds, whether every live thread is stopped); None as thread_times."""
        now = thread_times(self.pid)
        if now is None:
            return None
        for tid, (secs, _) in now.items():
            self.total += max(0.0, secs - self.seen.get(tid, 0.0))
        self.seen = {tid: secs for tid, (secs, _) in now.items()}
        return self.total, all(stopped for _, stopped in now.values())


@lru_cache(maxsize=1)
def warm_variant() -> tuple:
    """The fog program every worker draws before its first job (worker._warm_up)."""
    from fogbank.workers.cost import program_key
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    return program_key(StillParams.model_validate(preset_dict("default")))


class WorkerError(Exception):
    """A job did not produce its result; `status` and `retry_after` say how to answer."""

    def __init__(self, msg: str, status: int = 503, retry_after: int = 2):
        super().__init__(msg)
        self.status = status
        self.retry_after = retry_after


class DeadlineExceeded(WorkerError):
    """A job ran past its deadline. `stalled`: its worker made no progress (Supervisor.
    cpu_share under STALL_CPU_SHARE), so the server, not the job, is to blame; None when
    that could not be measured. `cpu_share`: the cores it used over the job."""

    def __init__(self, msg: str, stalled: bool | None = None, cpu_share: float | None = None, **kw):
        super().__init__(msg, **kw)
        self.stalled = stalled
        self.cpu_share = cpu_share


class QueueTimeout(WorkerError):
    pass


@dataclass
class Slot:
    """One worker process (a pebble pool of one) and what the supervisor knows of it."""
    lane: str
    index: int
    pool: ProcessPool
    pid: int | None = None
    rss: int = 0
    last_ok: float = 0.0
    jobs: int = 0                 # queued or running
    inflight: set = field(default_factory=set)   # their futures
    sessions: int = 0             # streaming sessions pinned here
    probing: bool = False
    started: float = field(default_factory=time.monotonic)
    compiled: set = field(default_factory=lambda: {warm_variant()})   # fog programs it has drawn
    # (monotonic s, CPU s, state) of its worker process, sampled each probe interval while
    # it has jobs (Supervisor.sample_cpu); cleared when the process changes
    cpu: deque = field(default_factory=lambda: deque(maxlen=256))
    progress: Progress = field(default_factory=lambda: Progress(None))   # of that process
    busy_since: float | None = None   # since when it has had jobs in flight (queued or running)
    # when a job of its worker last finished: set by pebble's thread as it happens, since the
    # caller's coroutine (which clears busy_since) may resume much later on a loaded machine
    finished: float = 0.0
    generation: int = 0   # counts hard replacements: the jobs of a killed worker are lost
    down_since: float | None = None   # killed or replaced then, and not rendered since

    def note_finished(self, fut) -> None:
        """A done-callback of each job's future (run by pebble's thread as the job ends):
        a job that ran to a result or an error is the worker's progress (`finished`); one
        cancelled (a caller gave up waiting for it) is not, or callers timing out on a
        stopped worker would keep it from ever looking stalled."""
        if not fut.cancelled():
            self.finished = time.monotonic()

    def worker_pid(self) -> int | None:
        """The pid of the slot's worker process as its pool knows it now (a replaced
        worker's before its first job reports it), else the last one a job reported."""
        try:   # pebble keeps its workers by pid; read defensively, its manager thread edits it
            pids = list(self.pool._pool_manager.worker_manager.workers)
        except (AttributeError, RuntimeError):
            pids = []
        return pids[0] if pids else self.pid

    def running(self) -> bool:
        return any(f.running() for f in self.inflight)

    def drew(self, key: tuple) -> None:
        """Remember a variant this worker compiled (a rough mirror of its program cache:
        forgotten wholesale past 48, as the worker's cache evicts)."""
        if len(self.compiled) >= 48:
            self.compiled = {warm_variant()}
        self.compiled.add(key)


class Lane:
    def __init__(self, name: str, count: int, sup: "Supervisor", nice: int):
        self.name = name
        self.sup = sup
        self.nice = nice
        self.slots = [Slot(name, i, self._pool()) for i in range(count)]

    def _pool(self) -> ProcessPool:
        s = self.sup.settings
        # one BLAS thread per worker (read when the spawned worker loads numpy): the noise
        # bake's contractions (kinds/noise_bake.py) otherwise start a thread per core in
        # every worker, against the other workers' raster threads; on 2 cores one thread
        # baked 128^3, 6 octaves in 0.7-1.5 s, a thread per core in 0.6-2.7 s
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
        return ProcessPool(max_workers=1, initializer=worker.init,
                           initargs=(s.gl_backend, s.gl_device, self.nice,
                                     (s.worker_cache_mb if self.name == "interactive" else s.batch_cache_mb) << 20,
                                     s.worker_memory_mb << 20, s.raster_threads, s.workers),
                           context=multiprocessing.get_context("spawn"))

    def least_loaded(self, by: str = "jobs") -> Slot:
        return min(self.slots, key=lambda s: (getattr(s, by), s.jobs, s.index))

    def recycle(self, slot: Slot, why: str, hard: bool = False, expected: ProcessPool | None = None) -> None:
        """Replace a slot's worker. Gently (between jobs): queued jobs finish on the old
        one, which then exits. Hard (a stuck worker): the old one is killed now. With
        `expected`, only if that pool is still the slot's (several failed jobs of one
        broken pool replace it once)."""
        if expected is not None and slot.pool is not expected:
            return
        old = slot.pool
        if hard:
            slot.generation += 1   # its jobs' callers give up on them now (Supervisor.call)
            slot.down_since = time.monotonic()
        slot.pool = self._pool()
        slot.pid = None
        slot.compiled = {warm_variant()}
        slot.started = time.monotonic()
        metrics.WORKER_RESTARTS.labels(self.name, why).inc()
        log.info("worker recycled", extra={"lane": self.name, "worker": slot.index, "why": why})

        def close() -> None:
            if not hard:
                old.close()
                old.join(timeout=120)
            if old.active:
                old.stop()
                old.join(timeout=10)
        threading.Thread(target=close, name="fogbank-recycle", daemon=True).start()

    def stop(self) -> None:
        for s in self.slots:
            s.pool.stop()
        for s in self.slots:
            s.pool.join(timeout=10)


class Supervisor:
    def __init__(self, settings):
        self.settings = settings
        s = settings
        self.interactive = Lane("interactive", s.workers, self, nice=0)
        self.batch = Lane("batch", s.batch_workers, self, nice=s.batch_nice) if s.batch_workers else None
        self.info: dict[str, str] = {}
        self._probe_task: asyncio.Task | None = None
        self.draining = False

    @property
    def lanes(self) -> list[Lane]:
        return [self.interactive] + ([self.batch] if self.batch else [])

    def slots(self) -> list[Slot]:
        return [s for lane in self.lanes for s in lane.slots]

    # ------------------------------------------------------------ lifecycle

    async def start(self, timeout: float = 120.0) -> dict[str, str]:
        """Start every worker and wait until each has answered a probe."""
        results = await asyncio.gather(*(self.call(slot, worker.probe, deadline=timeout, queue_s=timeout)
                                         for slot in self.slots()))
        self.info = results[0]["info"]
        self._probe_task = asyncio.get_running_loop().create_task(self._probe_loop(), name="fogbank-probes")
        return self.info

    async def stop(self) -> None:
        if self._probe_task:
            self._probe_task.cancel()
            try:
                await self._probe_task
            except asyncio.CancelledError:
                pass
        await asyncio.get_running_loop().run_in_executor(None, self._stop_lanes)

    def _stop_lanes(self) -> None:
        for lane in self.lanes:
            lane.stop()

    # ------------------------------------------------------------ jobs

    async def call(self, slot: Slot, fn: Callable, *args, deadline: float, queue_s: float | None = None) -> Any:
        """Run `fn(*args)` on `slot`'s worker. The job may wait in the queue up to
        `queue_s` and run up to `deadline` seconds; past either it is abandoned, its
        worker killed (if it had started) and a WorkerError raised."""
        queue_s = self.settings.queue_timeout_s if queue_s is None else queue_s
        lane = self.interactive if slot.lane == "interactive" else self.batch
        slot.jobs += 1
        t0 = time.monotonic()
        pool = slot.pool
        try:
            fut = pool.schedule(fn, args=args, timeout=deadline)
        except RuntimeError:   # pebble: the pool is not running (broken, see below)
            slot.jobs -= 1
            lane.recycle(slot, "broken", expected=pool)
            raise WorkerError("the renderer process was being replaced; retry", retry_after=2) from None
        if not slot.inflight:
            slot.busy_since = t0
        slot.inflight.add(fut)
        fut.add_done_callback(slot.note_finished)
        generation = slot.generation   # a hard replacement under the job changes it
        try:
            # asyncio.wait, not wait_for: since Python 3.11 a wait_for timeout and pebble's
            # deadline are the same TimeoutError class, and they must be told apart
            waiter = asyncio.wrap_future(fut)
            end = t0 + queue_s + deadline
            while True:   # until done, past the wait's end, or the worker was replaced under it
                done, _ = await asyncio.wait({waiter}, timeout=max(0.0, min(0.5, end - time.monotonic())))
                if done or time.monotonic() >= end or slot.generation != generation:
                    break
            if not done:
                waiter.cancel()
                fut.cancel()   # pebble kills the worker if the job had started
                if slot.generation != generation:
                    metrics.ERRORS.labels("worker_replaced").inc()
                    raise WorkerError(f"the {slot.lane} renderer stalled and was replaced; retry",
                                      retry_after=2)
                metrics.ERRORS.labels("queue_timeout").inc()
                since = max(slot.last_ok, slot.started + self.settings.worker_start_s)
                if not any(f.running() for f in slot.inflight) and time.monotonic() - since > queue_s:
                    # nothing started in all that time (after a new worker's allowance to
                    # start): the worker itself is stuck (a hung start, a stopped
                    # process), and no deadline can fire for it
                    log.error("worker stuck; replacing it", extra={"lane": slot.lane, "worker": slot.index})
                    lane.recycle(slot, "stuck", hard=True, expected=pool)
                raise QueueTimeout(f"the {slot.lane} renderer is busy: the job waited over "
                                   f"{queue_s + deadline:g} s", retry_after=5)
            out = waiter.result()
        except FutureTimeout:
            now = time.monotonic()
            # how much of a core the worker used while the job ran (pebble has killed it by
            # now; the samples are the probe loop's): none means it stalled
            share = self.cpu_share(slot, now - STALL_WINDOW_S - 0.5, now)
            stalled = None if share is None else (share < STALL_CPU_SHARE
                                                  and (self.cpu_renderer() or bool(slot.cpu[-1][2])))
            slot.started = now   # pebble starts a new worker: give it time to start
            slot.down_since = now
            slot.compiled = {warm_variant()}
            metrics.DEADLINE_KILLS.labels(slot.lane).inc()
            metrics.WORKER_RESTARTS.labels(slot.lane, "stalled" if stalled else "deadline").inc()
            log.warning("job past its deadline; worker killed",
                        extra={"lane": slot.lane, "worker": slot.index, "deadline_s": deadline,
                               "job": getattr(fn, "__name__", str(fn)), "cpu_share": share,
                               "stalled": stalled})
            if stalled:
                raise DeadlineExceeded(f"the {slot.lane} renderer stalled (it used {share:.2f} of a core "
                                       f"for {deadline:g} s) and was replaced; retry", stalled=True,
                                       cpu_share=share, retry_after=2) from None
            raise DeadlineExceeded(f"rendering took over {deadline:g} s and was stopped", stalled=stalled,
                                   cpu_share=share, retry_after=5) from None
        except (ProcessExpired, BrokenProcessPool, FutureCancelled) if slot.generation != generation else ():
            # the probe loop replaced a stalled worker under this job (its pool stopped): the
            # same answer as when the wait noticed it first
            metrics.ERRORS.labels("worker_replaced").inc()
            raise WorkerError(f"the {slot.lane} renderer stalled and was replaced; retry", retry_after=2) from None
        except ProcessExpired as exc:
            slot.started = slot.down_since = time.monotonic()
            slot.compiled = {warm_variant()}
            metrics.WORKER_RESTARTS.labels(slot.lane, "died").inc()
            log.error("worker died during a job", extra={"lane": slot.lane, "worker": slot.index,
                                                         "error": str(exc)})
            raise WorkerError(f"the renderer process died ({exc}); it has been restarted", retry_after=2) from None
        except BrokenProcessPool:
            # pebble marks a pool broken when its worker dies with no job running (the
            # initializer failed, or it was killed while idle): replace it
            lane.recycle(slot, "broken", expected=pool)
            raise WorkerError("the renderer process was lost; it has been replaced", retry_after=2) from None
        except FutureCancelled:
            raise WorkerError("the job was cancelled", retry_after=1) from None
        finally:
            slot.jobs -= 1
            slot.inflight.discard(fut)
            if not slot.inflight:
                slot.busy_since = None
        now = time.monotonic()
        slot.last_ok = now
        slot.down_since = None
        if out.get("pid") and slot.pid != out["pid"]:
            slot.pid = out["pid"]
        slot.rss = out.get("rss", slot.rss)
        metrics.WORKER_RSS.labels(slot.lane, str(slot.index)).set(slot.rss)
        metrics.QUEUE_WAIT.labels(slot.lane).observe(max(0.0, now - t0 - out.get("run_s", 0.0)))
        if out.get("recycle") and lane is not None:
            lane.recycle(slot, "memory", expected=pool)
        return out

    # ------------------------------------------------------------ health

    async def _probe_loop(self) -> None:
        s = self.settings
        loop = asyncio.get_running_loop()
        while True:
            await asyncio.sleep(min(s.probe_interval_s, 1.0))
            now = time.monotonic()
            for slot in self.slots():
                self.sample_cpu(slot, now)
                if not slot.running() and self.stalled(slot, now):
                    # jobs wait and the worker takes none, using no CPU (stopped, hung):
                    # replaced now, not after the queue's timeout (30 s). A stalled worker
                    # that runs a job is left to the job's deadline, which also tells the
                    # job's owner whom to blame (DeadlineExceeded.stalled)
                    log.error("worker stalled with jobs waiting; replacing it",
                              extra={"lane": slot.lane, "worker": slot.index})
                    lane = self.interactive if slot.lane == "interactive" else self.batch
                    slot.cpu.clear()
                    lane.recycle(slot, "stalled", hard=True)
                    continue
                if not slot.probing and now - slot.last_ok > s.probe_interval_s:
                    slot.probing = True
                    loop.create_task(self._probe(slot))

    async def _probe(self, slot: Slot) -> None:
        try:
            await self.call(slot, worker.probe, deadline=self.settings.probe_deadline_s,
                            queue_s=self.settings.liveness_s)
        except WorkerError as exc:
            log.warning("probe failed", extra={"lane": slot.lane, "worker": slot.index, "error": str(exc)})
        except Exception as exc:  # noqa: BLE001 - a probe never takes the loop down
            log.error("probe error", extra={"lane": slot.lane, "worker": slot.index, "error": repr(exc)})
        finally:
            slot.probing = False

    def sample_cpu(self, slot: Slot, now: float) -> None:
        """Note the CPU time of the slot's worker while it has jobs (forgotten when it has
        none: call() reads a job's samples before it lets the job go)."""
        if not slot.inflight:
            slot.cpu.clear()
            return
        pid = slot.worker_pid()
        if pid != slot.progress.pid:
            slot.cpu.clear()
            slot.progress = Progress(pid)
        stat = slot.progress.read()
        if stat is not None:
            slot.cpu.append((now, *stat))

    def cpu_share(self, slot: Slot, since: float, until: float) -> float | None:
        """The cores the slot's worker used on average between `since` and `until`, from
        its samples; None with fewer than two samples 1 s apart in that span (no /proc, a
        job too short to sample)."""
        pts = [(t, c) for t, c, _ in slot.cpu if since <= t <= until]
        if len(pts) < 2 or pts[-1][0] - pts[0][0] < 1.0:
            return None
        return (pts[-1][1] - pts[0][1]) / (pts[-1][0] - pts[0][0])

    def stalled(self, slot: Slot, now: float) -> bool:
        """The slot has had jobs in flight for STALL_WINDOW_S and its worker made no
        progress over that time (under STALL_CPU_SHARE of a core run or waited for; a
        worker with a job is running it, or starting, which takes CPU too). On a GPU, only
        when it is stopped as well (STALL_CPU_SHARE's comment)."""
        if slot.busy_since is None or not slot.cpu:
            return False
        # a job that finished is progress: the window starts there (a job that slept, then
        # the next one not yet marked running by pebble, is not a stall)
        since = max(slot.busy_since, slot.finished)
        if now - since < STALL_WINDOW_S:
            return False
        share = self.cpu_share(slot, max(since, now - STALL_WINDOW_S - 0.5), now)
        if share is None or share >= STALL_CPU_SHARE:
            return False
        return self.cpu_renderer() or slot.cpu[-1][2]

    def cpu_renderer(self) -> bool:
        """Whether the workers render on the CPU (llvmpipe, softpipe: every render is CPU work)."""
        r = (self.info.get("renderer") or "").lower()
        return "llvmpipe" in r or "softpipe" in r or "swrast" in r

    def slot_live(self, slot: Slot, now: float) -> bool:
        """The slot can render: it rendered (a probe or a job) within `liveness_s`, or it
        runs a job and is not stalled; and it has rendered since its worker was last
        killed or replaced (a new worker takes seconds to start and warm up)."""
        if self.stalled(slot, now):
            return False
        if slot.down_since is not None:   # replaced: live again once its new worker runs a job
            return slot.running()
        return now - slot.last_ok <= self.settings.liveness_s or slot.running()

    def lane_live(self, lane: Lane, now: float | None = None) -> bool:
        now = time.monotonic() if now is None else now
        return any(self.slot_live(s, now) for s in lane.slots)

    def live(self) -> tuple[bool, float]:
        """Alive when the interactive lane can render (some worker of it rendered within
        `liveness_s`, or runs a job without stalling): streams, the main job, need it, and
        the supervisor replaces a stuck worker well before a liveness probe's failure
        threshold runs out. A batch lane that cannot render fails readiness only
        (lanes_live). Also returns the age of the freshest success of any worker."""
        now = time.monotonic()
        age = min((now - s.last_ok for s in self.slots()), default=float("inf"))
        return self.lane_live(self.interactive, now), age

    def lanes_live(self) -> dict[str, bool]:
        """Each lane's name: whether it can render (lane_live)."""
        now = time.monotonic()
        return {lane.name: self.lane_live(lane, now) for lane in self.lanes}

    def status(self) -> list[dict[str, Any]]:
        now = time.monotonic()
        return [{"lane": s.lane, "worker": s.index, "pid": s.pid, "rss_mb": round(s.rss / 2**20, 1),
                 "jobs": s.jobs, "sessions": s.sessions,
                 "last_ok_s": round(now - s.last_ok, 2) if s.last_ok else None,
                 "live": self.slot_live(s, now), "stalled": self.stalled(s, now)}
                for s in self.slots()]

    def queue_depth(self) -> int:
        return sum(s.jobs for s in self.slots())

    def tree_rss(self) -> int:
        """Memory of the web process and all its descendants (bytes)."""
        return proctree.tree_rss_bytes()
