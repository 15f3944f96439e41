"""Prometheus metrics (prometheus-client), served at /metrics."""

from __future__ import annotations

from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Gauge, Histogram, generate_latest

REGISTRY = CollectorRegistry()
CONTENT_TYPE = CONTENT_TYPE_LATEST
_MS = (2, 5, 10, 20, 35, 50, 75, 100, 150, 250, 500, 1000, 2500, 5000)

FRAMES = Counter("fogbank_frames_total", "stream frames sent", registry=REGISTRY)
STILLS = Counter("fogbank_stills_total", "stills rendered", ["format"], registry=REGISTRY)
RENDER_MS = Histogram("fogbank_render_ms", "render time of a frame or still, ms", buckets=_MS,
                      registry=REGISTRY)
ENCODE_MS = Histogram("fogbank_encode_ms", "encode time of a stream frame, ms", buckets=_MS,
                      registry=REGISTRY)
SESSIONS = Gauge("fogbank_sessions", "open streaming sessions", registry=REGISTRY)
QUEUE = Gauge("fogbank_render_queue", "jobs waiting for the render thread", registry=REGISTRY)
ERRORS = Counter("fogbank_errors_total", "errors by kind", ["kind"], registry=REGISTRY)


def render() -> bytes:
    return generate_latest(REGISTRY)
