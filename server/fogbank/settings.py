"""Every setting of the service, in one place (environment variables FOGBANK_*)."""

from __future__ import annotations

from functools import lru_cache
from typing import Literal

from pydantic import Field, ValidationError
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="FOGBANK_", extra="ignore")

    host: str = Field("127.0.0.1", description="address the server binds")
    port: int = Field(8000, ge=1, le=65535, description="TCP port")
    gl_backend: Literal["auto", "egl", "default"] = Field(
        "auto", description="'auto' and 'egl' use EGL (the GPU where there is one, else llvmpipe); "
        "'default' lets glcontext pick (GLX/WGL/CGL)")
    gl_device: int | None = Field(None, ge=0, description="EGL device index; unset picks the first")
    raster_threads: int = Field(0, ge=0, le=256, description="llvmpipe's raster threads in each render "
                                "worker (LP_NUM_THREADS); 0: one more than the worker's share of the "
                                "cores (render/gl.py raster_threads); a GPU ignores it")
    workers: int = Field(1, ge=1, le=64, description="interactive render worker processes (stream "
                         "frames, cheap stills), each with its own GL context")
    frames_per_worker: int = Field(1, ge=1, le=8, description="stream frames on one "
                                   "interactive worker at once when the next is a preview; a "
                                   "frame of a stream that only plays may queue one more "
                                   "(stream/streaming.py Streamer.queue_room)")
    batch_workers: int = Field(1, ge=0, le=64, description="batch render worker processes (costly "
                               "stills, transmittance); 0 runs everything on the interactive ones")
    batch_nice: int = Field(10, ge=0, le=19, description="CPU niceness of batch workers")
    render_timeout_s: float = Field(30.0, gt=0, le=3600, description="deadline of a still or "
                                    "transmittance job; past it the worker is killed and the client gets 503")
    frame_deadline_s: float = Field(10.0, gt=0, le=600, description="deadline of one stream frame")
    queue_timeout_s: float = Field(30.0, gt=0, le=3600, description="longest wait for a worker "
                                   "before a job starts; beyond, 503")
    worker_cache_mb: int = Field(256, ge=16, le=65536, description="GL cache budget of each worker "
                                 "(render targets and cached scene passes), MiB: two streams' scene "
                                 "passes at 1280x720 or ten at 640x360")
    batch_cache_mb: int = Field(128, ge=16, le=65536, description="GL cache budget of each batch "
                                "worker, MiB (stills rarely reuse a cached scene pass)")
    worker_memory_mb: int = Field(768, ge=128, le=262144, description="resident memory above which "
                                  "a worker frees its caches, and is replaced if still over, MiB")
    still_budget_s: float = Field(20.0, gt=0, le=3600, description="estimated render seconds a still "
                                  "may cost (on the reference machine, times cost_scale); beyond, 422")
    still_memory_mb: int = Field(900, ge=16, le=262144, description="estimated GL memory a still may "
                                 "take, MiB; beyond, 422")
    interactive_cost_s: float = Field(0.5, ge=0, le=60, description="stills estimated below this "
                                      "run on the interactive workers, the rest on the batch ones")
    cost_scale: float = Field(1.0, gt=0, le=100, description="multiplies cost estimates (below 1 on "
                              "a GPU)")
    worker_start_s: float = Field(30.0, gt=0, le=600, description="how long a new worker may take "
                                  "to start before a worker that starts no job is taken for stuck")
    probe_interval_s: float = Field(1.0, gt=0, le=60, description="an idle worker is probed this often")
    probe_deadline_s: float = Field(5.0, gt=0, le=600, description="deadline of a probe")
    liveness_s: float = Field(10.0, gt=0, le=600, description="/healthz fails when no interactive "
                              "worker has rendered (a probe or a job) for this long and none runs a job "
                              "without stalling; /readyz, when a lane has none")
    stills_cache_mb: int = Field(64, ge=0, le=65536, description="encoded stills kept for repeats, MiB")
    max_sessions: int = Field(32, ge=1, le=10000, description="streaming sessions per process; "
                              "the next is refused with close code 1013")
    max_stills: int = Field(4, ge=1, le=256, description="distinct still renders at once; more wait "
                            "(up to max_queued_stills, and queue_timeout_s each), then 503. Requests "
                            "for a still already rendering wait for that render (single flight)")
    max_queued_stills: int = Field(64, ge=0, le=100000, description="distinct stills that may wait "
                                   "for one of max_stills places; beyond, 503 with Retry-After")
    max_viewers: int = Field(64, ge=1, le=10000, description="viewers of one live session (a "
                             "shared session's link); the next is refused with close code 1013. A viewer "
                             "costs a socket and its share of the sends, not a render")
    live_resume_s: float = Field(10.0, ge=0, le=300, description="how long a live session's viewers wait "
                                 "for its presenter to reconnect (a network blip) before it ends for them; "
                                 "0: it ends when the presenter's socket does")
    max_viewers_per_client: int = Field(64, ge=1, le=10000, description="viewers of live sessions "
                                        "that one client address (an IPv6 one: its /64) may hold, over all "
                                        "sessions (a class behind one NAT shares an address); the next is "
                                        "refused with 1013")
    messages_per_s: float = Field(120.0, gt=0, description="per-socket message rate (token bucket)")
    message_burst: int = Field(240, ge=1, description="per-socket burst of messages")
    max_sessions_per_client: int = Field(8, ge=1, le=10000, description="streaming sessions one "
                                         "client address (an IPv6 one: its /64) may hold (a classroom "
                                         "behind one NAT shares an address); the next is refused with 1013")
    yield_after_s: float = Field(20.0, gt=0, le=86400, description="a session paused (time "
                                 "stopped, no drag) that has sent nothing this long gives its place to a new "
                                 "session when the server or its address is full (closed with 4408; the page "
                                 "resumes it on the next input)")
    silent_yield_s: float = Field(5.0, gt=0, le=3600, description="a session that has sent no message "
                                  "this long after connecting gives its place likewise")
    idle_timeout_s: float = Field(300.0, gt=0, le=86400, description="a WebSocket that sends nothing "
                                  "this long is closed (code 4408)")
    ack_timeout_s: float = Field(30.0, gt=0, le=3600, description="a WebSocket that leaves frames "
                                 "unacknowledged this long is closed (code 4408)")
    max_body_bytes: int = Field(2 << 20, ge=1024, le=1 << 30, description="largest request body; beyond, 413")
    max_url_bytes: int = Field(32768, ge=1024, le=1 << 20, description="longest request target "
                               "(path and query); beyond, 414")
    head_timeout_s: float = Field(10.0, gt=0, le=3600, description="a request's line and headers "
                                  "must arrive within this of the connection (or of the last answer on "
                                  "it); else 408 and the connection is closed")
    body_timeout_s: float = Field(30.0, gt=0, le=3600, description="a request's body must arrive "
                                  "within this of its headers; else 408 and the connection is closed")
    max_headers: int = Field(100, ge=8, le=10000, description="most request headers; beyond, 431")
    max_header_bytes: int = Field(65536, ge=1024, le=1 << 20, description="largest total size of "
                                  "the request headers; beyond, 431")
    forwarded_allow_ips: str = Field("127.0.0.1", description="proxies whose X-Forwarded-For/-Proto "
                                     "are trusted (comma-separated, or '*'): the client address that "
                                     "max_sessions_per_client counts, and the scheme the Origin check uses")
    allowed_hosts: str = Field("localhost,127.0.0.1,::1", description="comma-separated host names "
                               "(without port) this server answers to, besides the address it binds; '*' any. "
                               "Others get 400 (a WebSocket, 403): a site whose name is made to resolve to "
                               "this server (DNS rebinding) sends its own name. /healthz, /readyz and "
                               "/metrics also answer any IP address (a probe's or scraper's Host)")
    allowed_origins: str = Field("", description="comma-separated Origins allowed on /ws besides "
                                 "the server's own host; '*' allows any")


class SettingsError(ValueError):
    """A setting's value is not allowed; the message names the key and the value."""


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    try:
        return Settings()
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            key = "FOGBANK_" + "_".join(str(p) for p in err["loc"]).upper()
            lines.append(f"{key}={err.get('input')!r}: {err['msg']}")
        raise SettingsError("bad setting: " + "; ".join(lines)) from None
