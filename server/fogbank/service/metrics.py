"""Prometheus metrics (prometheus-client), served at /metrics."""

from __future__ import annotations

from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Gauge, Histogram, generate_latest

REGISTRY = CollectorRegistry()
CONTENT_TYPE = CONTENT_TYPE_LATEST
_MS = (2, 5, 10, 20, 35, 50, 75, 100, 150, 250, 500, 1000, 2500, 5000)

FRAMES = Counter("fogbank_frames_total", "stream frames sent", registry=REGISTRY)
STILLS = Counter("fogbank_stills_total", "stills rendered", ["format"], registry=REGISTRY)
COALESCED = Counter("fogbank_stills_coalesced_total", "still requests answered by a render another "
                    "request of the same still had started", registry=REGISTRY)
RENDER_MS = Histogram("fogbank_render_ms", "render time of a frame or still, ms", buckets=_MS,
                      registry=REGISTRY)
ENCODE_MS = Histogram("fogbank_encode_ms", "encode time of a stream frame, ms", buckets=_MS,
                      registry=REGISTRY)
SESSIONS = Gauge("fogbank_sessions", "open streaming sessions", registry=REGISTRY)
VIEWERS = Gauge("fogbank_live_viewers", "viewers of live sessions (stream/live.py)", registry=REGISTRY)
QUEUE = Gauge("fogbank_render_queue", "jobs waiting for the render thread", registry=REGISTRY)
WORKER_RESTARTS = Counter("fogbank_worker_restarts_total", "render workers replaced, by lane and why "
                          "(deadline: killed past a job's deadline; died; memory: over its budget)",
                          ["lane", "why"], registry=REGISTRY)
DEADLINE_KILLS = Counter("fogbank_deadline_kills_total", "jobs stopped at their deadline (worker killed)",
                         ["lane"], registry=REGISTRY)
WORKER_RSS = Gauge("fogbank_worker_rss_bytes", "resident memory of each render worker, after its last job",
                   ["lane", "worker"], registry=REGISTRY)
TREE_RSS = Gauge("fogbank_tree_rss_bytes", "resident memory of the web process and its workers",
                 registry=REGISTRY)
QUEUE_WAIT = Histogram("fogbank_queue_wait_seconds", "time a job waited for its worker (incl. transfer)",
                       ["lane"], buckets=(0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30),
                       registry=REGISTRY)
ERRORS = Counter("fogbank_errors_total", "errors by kind", ["kind"], registry=REGISTRY)


def render() -> bytes:
    return generate_latest(REGISTRY)
