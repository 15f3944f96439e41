"""REST routes: stills, transmittance, schema, presets, health; the static page."""

from __future__ import annotations

import asyncio
import hashlib
import json
import math
import logging
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from contextlib import asynccontextmanager
from typing import Any, Literal

import numpy as np
from fastapi import FastAPI, HTTPException, Request, WebSocket
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from pydantic import BaseModel, Field, ValidationError

from . import STATIC_DIR, __version__, metrics
from . import presets as P
from .encode import MEDIA_TYPES, encode
from .params import FogParams, StillParams, Strict, Vec3
from .render_thread import RenderThread
from .security import SecurityHeaders, origin_allowed
from .settings import Settings, get_settings
from .streaming import Streamer, websocket_endpoint
from .urlstate import URLError, decode
from .urlstate import encode as encode_url

log = logging.getLogger("fogbank.api")
MAX_RAYS = 65536


class Ray(Strict):
    origin: Vec3 = Field(description="m")
    direction: Vec3 = Field(description="normalised by the server; not all zero",
                            json_schema_extra={"contains": {"not": {"const": 0}}})
    length: float = Field(ge=0, le=1e6, strict=True, description="m")
    time: float = Field(0.0, ge=0, le=1e6, strict=True, description="s")


class TransmittanceRequest(Strict):
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="a patch over the default preset (FogParams fields)")
    rays: list[Ray] = Field(min_length=1, max_length=MAX_RAYS)


class TransmittanceResponse(BaseModel):
    transmittance: list[float]
    renderer: str


def _clean(e: dict) -> dict:
    """A JSON-safe error: loc, msg, type, and the offending input when it is small."""
    out = {"loc": list(e.get("loc", ())), "msg": str(e.get("msg", "")), "type": e.get("type", "")}
    v = e.get("input")
    if isinstance(v, (int, str, bool)) and len(str(v)) <= 200:
        out["input"] = v
    elif isinstance(v, float):
        out["input"] = v if math.isfinite(v) else str(v)
    return out


def _validation_error(exc: ValidationError, prefix: tuple) -> RequestValidationError:
    return RequestValidationError([dict(e, loc=(*prefix, *e["loc"]))
                                   for e in exc.errors(include_url=False)])


def resolve(patch: dict, cls=StillParams, prefix: tuple = ("body",)):
    """A request's params: `patch` merged over the default preset, validated."""
    if not isinstance(patch, dict):
        raise RequestValidationError([{"loc": list(prefix), "msg": "expected a JSON object",
                                       "type": "dict_type"}])
    base = P.preset_dict("default")
    if cls is StillParams:
        base.update(width=StillParams.model_fields["width"].default,
                    height=StillParams.model_fields["height"].default)
    try:
        return cls.model_validate(P.merge(base, patch))
    except ValidationError as exc:
        raise _validation_error(exc, prefix) from None


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    state: dict[str, Any] = {}

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        rt = RenderThread(settings.gl_backend, settings.gl_device)
        await asyncio.get_running_loop().run_in_executor(None, rt.wait_ready)
        log.info("renderer: %s", rt.info)
        state["render"] = rt
        app.state.render = rt   # reachable for tests and fault injection
        state["pool"] = ThreadPoolExecutor(settings.encode_threads, thread_name_prefix="encode")
        state["cache"] = OrderedDict()
        state["stills"] = 0
        state["streamer"] = Streamer(rt, state["pool"], settings=settings)
        state["streamer"].start()
        yield
        await state["streamer"].stop()
        rt.stop()
        state["pool"].shutdown(wait=False)

    app = FastAPI(title="fogbank", version=__version__, lifespan=lifespan,
                  description="Analytic fog over a 3D scene, rendered on the server. "
                              "Every look is a URL: the same query works on the page and on "
                              "/api/still.png.")

    @app.exception_handler(RequestValidationError)
    async def _422(request: Request, exc: RequestValidationError):
        return JSONResponse({"detail": [_clean(e) for e in exc.errors()]}, status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException):
        if exc.status_code == 400 and "parsing the body" in str(exc.detail):
            # a body that is not JSON (or not UTF-8): bad input like any other, 422
            return JSONResponse({"detail": [{"loc": ["body"], "msg": "the body is not valid JSON",
                                             "type": "json_invalid"}]}, status_code=422)
        return JSONResponse({"detail": exc.detail}, status_code=exc.status_code,
                            headers=getattr(exc, "headers", None))

    async def _run(fn):
        fut = state["render"].submit(fn)
        try:
            return await asyncio.wait_for(asyncio.wrap_future(fut), settings.render_timeout_s)
        except asyncio.TimeoutError:
            fut.cancel()
            raise HTTPException(503, f"the renderer did not answer within {settings.render_timeout_s:g} s",
                                headers={"Retry-After": "5"}) from None
        except HTTPException:
            raise
        except Exception as exc:  # noqa: BLE001 - a renderer fault fails this request only
            metrics.ERRORS.labels("render").inc()
            log.error("render failed", extra={"error": f"{type(exc).__name__}: {exc}"})
            raise HTTPException(500, f"render failed ({type(exc).__name__}): {exc}") from None

    async def _still(still: StillParams, fmt: str, request: Request) -> Response:
        info = state["render"].info
        key = f"{__version__}|{info.get('renderer')}|{fmt}|{encode_url(still)}"
        etag = '"' + hashlib.sha256(key.encode()).hexdigest()[:32] + '"'
        headers = {"ETag": etag, "Cache-Control": "public, max-age=3600",
                   "X-Fogbank-Query": encode_url(still)}
        if request.headers.get("if-none-match") == etag:
            return Response(status_code=304, headers=headers)
        cache: OrderedDict = state["cache"]
        if etag in cache:
            cache.move_to_end(etag)
            return Response(cache[etag], media_type=MEDIA_TYPES[fmt], headers=headers)
        if state["stills"] >= settings.max_stills:
            metrics.ERRORS.labels("busy").inc()
            raise HTTPException(503, f"{settings.max_stills} stills are rendering; retry shortly",
                                headers={"Retry-After": "2"})
        state["stills"] += 1
        try:
            img = await _run(lambda r: r.render(still))
            loop = asyncio.get_running_loop()
            data = await loop.run_in_executor(state["pool"], encode, img, fmt)
        finally:
            state["stills"] -= 1
        metrics.STILLS.labels(fmt).inc()
        cache[etag] = data
        while len(cache) > 32:
            cache.popitem(last=False)
        return Response(data, media_type=MEDIA_TYPES[fmt], headers=headers)

    @app.get("/api/still.{fmt}", summary="Render a still from URL params",
             responses={200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
                        304: {"description": "not modified (If-None-Match)"},
                        422: {"description": "a param is invalid; the body names it"},
                        503: {"description": "busy or slow renderer; see Retry-After"}})
    async def still_get(fmt: Literal["png", "jpg", "webp"], request: Request):
        """Every param of the page URL (see /api/schema), plus `width` and `height`;
        anything left out comes from the default preset (or `preset=NAME`)."""
        try:
            value, _ = decode(request.url.query, StillParams)
        except URLError as exc:
            raise RequestValidationError(exc.errors) from None
        try:
            still = StillParams.model_validate(value)
        except ValidationError as exc:
            raise _validation_error(exc, ("query",)) from None
        return await _still(still, fmt, request)

    @app.post("/api/still", summary="Render a still from JSON params",
              responses={200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
                         503: {"description": "busy or slow renderer; see Retry-After"}},
              openapi_extra={"requestBody": {"required": False, "content": {"application/json": {
                  "schema": {"type": "object", "description": "StillParams fields (see /api/schema), "
                             "a patch over the default preset"}}}}})
    async def still_post(request: Request, format: Literal["png", "jpg", "webp"] = "png"):
        raw = await request.body()
        try:
            body = json.loads(raw) if raw.strip() else {}
        except (ValueError, RecursionError) as exc:
            raise RequestValidationError([{"loc": ["body"], "msg": f"malformed JSON: {exc}",
                                           "type": "json_invalid"}]) from None
        return await _still(resolve(body), format, request)

    @app.post("/api/transmittance", response_model=TransmittanceResponse,
              responses={503: {"description": "slow renderer; see Retry-After"}},
              summary="Transmittance of rays through the fog, by the frame's own GLSL")
    async def transmittance(req: TransmittanceRequest):
        fog = resolve(req.params, FogParams, ("body", "params"))
        O = np.array([r.origin for r in req.rays], dtype=np.float64)
        W = np.array([r.direction for r in req.rays], dtype=np.float64)
        big = np.abs(W).max(axis=1)
        bad = np.nonzero(~(big > 0))[0]
        if len(bad):
            raise RequestValidationError([{"loc": ["body", "rays", int(bad[0]), "direction"],
                                           "msg": "direction must be a non-zero vector",
                                           "type": "value_error"}])
        W = W / big[:, None]                  # scaled first: tiny vectors do not underflow
        W = W / np.linalg.norm(W, axis=1)[:, None]
        D = np.array([r.length for r in req.rays])
        Tm = np.array([r.time for r in req.rays])
        T = await _run(lambda r: r.transmittance(fog, O, W, D, Tm))
        return {"transmittance": [float(x) for x in T],
                "renderer": state["render"].info.get("renderer", "")}

    @app.get("/api/schema", summary="JSON Schema of the params (ranges, slider steps, units)")
    async def schema():
        return StillParams.model_json_schema()

    @app.get("/api/presets", summary="The named looks")
    async def presets_list():
        out = []
        for name, p in P.presets().items():
            fog = FogParams.model_validate(P.preset_dict(name))
            out.append({"name": name, "title": p["title"], "description": p["description"],
                        "query": encode_url(fog), "params": P.preset_dict(name)})
        return out

    @app.get("/healthz", summary="Liveness and the renderer in use")
    async def healthz():
        rt = state.get("render")
        info = rt.info if rt else {}
        return {"status": "ok", "renderer": info.get("renderer"), "gl_version": info.get("version"),
                "queue": rt.depth() if rt else 0}

    @app.websocket("/ws")
    async def ws(websocket: WebSocket):
        if not origin_allowed(websocket.headers.get("origin"), websocket.headers.get("host"),
                              settings.allowed_origins):
            metrics.ERRORS.labels("origin").inc()
            await websocket.close(code=1008, reason="origin not allowed")
            return
        await websocket_endpoint(websocket, state["streamer"], state["render"].info)

    @app.get("/metrics", include_in_schema=False)
    async def metrics_endpoint():
        rt = state.get("render")
        metrics.QUEUE.set(rt.depth() if rt else 0)
        metrics.SESSIONS.set(len(state["streamer"].clients) if "streamer" in state else 0)
        return Response(metrics.render(), media_type=metrics.CONTENT_TYPE)

    @app.get("/", include_in_schema=False)
    async def index():
        return FileResponse(STATIC_DIR / "index.html")

    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    app.add_middleware(SecurityHeaders)
    return app
