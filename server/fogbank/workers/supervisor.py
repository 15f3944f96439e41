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
    pass


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
        slot.inflight.add(fut)
        try:
            # asyncio.wait, not wait_for: since Python 3.11 a wait_for timeout and pebble's
            # deadline are the same TimeoutError class, and they must be told apart
            waiter = asyncio.wrap_future(fut)
            done, _ = await asyncio.wait({waiter}, timeout=queue_s + deadline)
            if not done:
                waiter.cancel()
                fut.cancel()   # pebble kills the worker if the job had started
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
            slot.started = time.monotonic()   # pebble starts a new worker: give it time to start
            slot.compiled = {warm_variant()}
            metrics.DEADLINE_KILLS.labels(slot.lane).inc()
            metrics.WORKER_RESTARTS.labels(slot.lane, "deadline").inc()
            log.warning("job past its deadline; worker killed",
                        extra={"lane": slot.lane, "worker": slot.index, "deadline_s": deadline,
                               "job": getattr(fn, "__name__", str(fn))})
            raise DeadlineExceeded(f"rendering took over {deadline:g} s and was stopped", retry_after=5) from None
        except ProcessExpired as exc:
            slot.started = time.monotonic()
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
        now = time.monotonic()
        slot.last_ok = now
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
            await asyncio.sleep(s.probe_interval_s)
            now = time.monotonic()
            for slot in self.slots():
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

    def live(self) -> tuple[bool, float]:
        """Alive when some worker rendered (a probe or a job) within `liveness_s`;
        also returns the age of the freshest success."""
        now = time.monotonic()
        age = min((now - s.last_ok for s in self.slots()), default=float("inf"))
        return age <= self.settings.liveness_s, age

    def status(self) -> list[dict[str, Any]]:
        now = time.monotonic()
        return [{"lane": s.lane, "worker": s.index, "pid": s.pid, "rss_mb": round(s.rss / 2**20, 1),
                 "jobs": s.jobs, "sessions": s.sessions,
                 "last_ok_s": round(now - s.last_ok, 2) if s.last_ok else None}
                for s in self.slots()]

    def queue_depth(self) -> int:
        return sum(s.jobs for s in self.slots())

    def tree_rss(self) -> int:
        """Memory of the web process and all its descendants (bytes)."""
        return proctree.tree_rss_bytes()
