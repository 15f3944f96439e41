"""The one thread that owns the GL context; everything else talks to it through a queue.

`submit(fn)` queues `fn(renderer)` and returns a concurrent Future. A job that raises
fails only its own future. A GL-level failure (lost context, GL error) rebuilds the
renderer before the next job, so other requests go on.
"""

from __future__ import annotations

import logging
import queue
import threading
from concurrent.futures import Future
from typing import Any, Callable

from .renderer import Renderer, create_context

log = logging.getLogger("fogbank.render")


class RenderThread:
    def __init__(self, backend: str = "auto", device: int | None = None):
        self._backend, self._device = backend, device
        self._queue: queue.Queue = queue.Queue()
        self._ready = threading.Event()
        self._info: dict[str, str] = {}
        self._error: BaseException | None = None
        self.generation = 0   # how many times the renderer was rebuilt
        self._thread = threading.Thread(target=self._run, name="fogbank-render", daemon=True)
        self._thread.start()

    def wait_ready(self, timeout: float = 60.0) -> dict[str, str]:
        if not self._ready.wait(timeout):
            raise TimeoutError("the renderer did not start in time")
        if self._error is not None:
            raise RuntimeError(f"the renderer failed to start: {self._error}") from self._error
        return self._info

    @property
    def info(self) -> dict[str, str]:
        return self._info

    def submit(self, fn: Callable[[Renderer], Any]) -> Future:
        fut: Future = Future()
        self._queue.put((fn, fut))
        return fut

    def depth(self) -> int:
        return self._queue.qsize()

    def stop(self, timeout: float = 10.0) -> None:
        self._queue.put(None)
        self._thread.join(timeout)

    def _start(self) -> Renderer:
        ctx = create_context(self._backend, self._device)
        r = Renderer(ctx)
        self._info = r.info()
        return r

    def _run(self) -> None:
        try:
            renderer = self._start()
        except BaseException as exc:  # noqa: BLE001 - reported through wait_ready
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        while True:
            item = self._queue.get()
            if item is None:
                break
            fn, fut = item
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                result = fn(renderer)
                err = renderer.ctx.error
                if err != "GL_NO_ERROR":
                    raise RuntimeError(f"GL error after a job: {err}")
                fut.set_result(result)
            except BaseException as exc:  # noqa: BLE001 - the job's own failure
                if not fut.done():
                    fut.set_exception(exc)
                if _is_gl_failure(exc) or not _healthy(renderer):
                    log.warning("renderer failed (%s); rebuilding it", exc)
                    try:
                        renderer.ctx.release()
                    except Exception:  # noqa: BLE001
                        pass
                    renderer = self._start()
                    self.generation += 1


def _healthy(renderer: Renderer) -> bool:
    """Whether the renderer's context still answers (a released or lost one does not)."""
    try:
        return isinstance(renderer.ctx.error, str)
    except Exception:  # noqa: BLE001
        return False


def _is_gl_failure(exc: BaseException) -> bool:
    name = type(exc).__module__ + "." + type(exc).__name__
    return "moderngl" in name or "GL error" in str(exc)
