"""REST routes: stills, transmittance, schema, presets, health; the static page."""

from __future__ import annotations

import asyncio
import hashlib
import json
import logging
from collections import OrderedDict
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import fastapi_offline
import numpy as np
from fastapi import FastAPI, HTTPException, Request, WebSocket
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from pydantic import BaseModel, Field, ValidationError, model_validator

from fogbank import STATIC_DIR, __version__
from fogbank.model import errors

from fogbank.workers import cost

from fogbank.service import metrics

from fogbank.service import openapi

from fogbank.workers import worker
from fogbank.model import presets as P
from fogbank.render.encode import MEDIA_TYPES
from fogbank.service.limits import RequestLimits
from fogbank.model.params import LAYER_CLASSES, FogParams, StillParams
from fogbank.model.suggest import suggest_layer
from fogbank.model.layer_profile import KINDS_EDITED, profile
from fogbank.model.fields import RAY_LIMIT, Direction, Int, Position, Strict
from fogbank.service.security import HostCheck, SecurityHeaders, allowed_hosts, origin_allowed
from fogbank.workers.supervisor import DeadlineExceeded, Supervisor, WorkerError
from fogbank.settings import Settings, get_settings
from fogbank.stream.streaming import Streamer, websocket_endpoint
from fogbank.model.urlstate import URLError, decode, shareable
from fogbank.model.urlstate import encode as encode_url

log = logging.getLogger("fogbank.service.api")
SWAGGER_DIR = Path(fastapi_offline.__file__).parent / "static"   # Swagger UI, shipped by a package
MAX_RAYS = 16384
MAX_RAY_TIMES = 16   # distinct ray times per request (each simulates the particles once)


class Ray(Strict):
    origin: Position = Field(description="m, each axis within the scene's position limit")
    direction: Direction = Field(description="normalised by the server; not all zero",
                            json_schema_extra={"contains": {"not": {"const": 0}}})
    length: float = Field(ge=0, le=RAY_LIMIT, strict=True, description="m")
    time: float = Field(0.0, ge=0, le=1e6, strict=True, description="s")


class SuggestRequest(Strict):
    kind: Literal[tuple(LAYER_CLASSES)] = Field(description="the new layer's kind")   # type: ignore[valid-type]
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="the look it joins: a patch over the default preset")


PLOT_BUDGET_S = 2.0   # a ray plot follows the cursor: a look whose plot costs more is refused


class RayPlotRequest(Strict):
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="the look: a patch over the default preset")
    x: float = Field(ge=0, le=4096, strict=True, description="the pixel's column, from the left (px)")
    y: float = Field(ge=0, le=4096, strict=True, description="the pixel's row, from the top (px)")
    width: Int = Field(ge=16, le=4096, description="the view's width (px)")
    height: Int = Field(ge=16, le=4096, description="the view's height (px)")



EditedLayer = Annotated[Union[tuple(LAYER_CLASSES[k] for k in KINDS_EDITED)], Field(discriminator="kind")]


class LayerProfileRequest(Strict):
    layer: EditedLayer = Field(description=f"a layer of kind {' or '.join(KINDS_EDITED)}")  # type: ignore[valid-type]
    points: list[Annotated[float, Field(strict=True, ge=-1e6, le=1e6)]] | None = Field(None, max_length=32,
                                       description="new values at the profile's points (the editor's drag); "
                                                   "the coefficients follow")


class TransmittanceRequest(Strict):
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="a patch over the default preset (FogParams fields)")
    rays: list[Ray] = Field(min_length=1, max_length=MAX_RAYS,
                            description=f"at most {MAX_RAYS} rays with at most {MAX_RAY_TIMES} "
                                        "distinct times (the particle state is computed once per time)")

    @model_validator(mode="after")
    def _times(self) -> "TransmittanceRequest":
        n = len({r.time for r in self.rays})
        if n > MAX_RAY_TIMES:
            raise ValueError(f"{n} distinct ray times; at most {MAX_RAY_TIMES} are allowed per request")
        return self


class TransmittanceResponse(BaseModel):
    transmittance: list[float]
    renderer: str


class LightResponse(BaseModel):
    transmittance: list[float] = Field(description="each ray's T, as /api/transmittance gives it")
    in_scattered: list[float] = Field(description="J: the sunlight the ray's fog scatters toward its origin, as a "
                                      "share of the sun's in-scattering without fog toward the sun or shadows "
                                      "(0 to 1 - T of the medium): the single-scattering integral of "
                                      "-dT/ds T_sun V over the ray")
    medium_transmittance: list[float] = Field(description="the fog's own T along the ray, without the cutoff "
                                              "distance or max opacity: the T that J is integrated with")
    # an RGB triple as a 3-long list, not a tuple: a tuple's prefixItems inside a response's
    # `items` is read as the OpenAPI 3.0 list form by schemathesis' response checks
    light: list[Annotated[list[float], Field(min_length=3, max_length=3)]] = Field(
        description="the fog's light along the ray, linear RGB, as the composite adds it to T times the "
                    "surface: (1 - T) fog_color + sun colour x intensity x scatter_color x scatter x phase x J "
                    "(phase: the look's lobe at the angle between the ray and the sun)")
    renderer: str


def _validation_error(exc: ValidationError, prefix: tuple) -> RequestValidationError:
    return RequestValidationError(errors.from_validation(exc, prefix))


def resolve(patch: dict, cls=StillParams, prefix: tuple = ("body",)):
    """A request's params: `patch` merged over the default preset, validated."""
    if not isinstance(patch, dict):
        raise RequestValidationError([errors.error(prefix, "expected a JSON object", "dict_type")])
    base = P.preset_dict("default")
    if cls is StillParams:
        base.update(width=StillParams.model_fields["width"].default,
                    height=StillParams.model_fields["height"].default)
    try:
        return P.patched(patch, base, cls)
    except ValidationError as exc:
        raise _validation_error(exc, prefix) from None



class StillCache:
    """Encoded stills by ETag, least recently used first out, bounded in bytes."""

    def __init__(self, budget: int):
        self.budget = budget
        self.items: OrderedDict[str, bytes] = OrderedDict()
        self.size = 0

    def get(self, key: str) -> bytes | None:
        if key in self.items:
            self.items.move_to_end(key)
            return self.items[key]
        return None

    def put(self, key: str, data: bytes) -> None:
        if len(data) > self.budget or key in self.items:
            return
        self.items[key] = data
        self.size += len(data)
        while self.size > self.budget:
            self.size -= len(self.items.popitem(last=False)[1])


def none_match(header: str | None, etag: str) -> bool:
    """Whether an If-None-Match header names `etag` (RFC 9110 13.1.2): `*`, or a list of
    entity tags compared weakly (W/"x" matches "x"). Only an exact single tag matched before."""
    if not header:
        return False
    if header.strip() == "*":
        return True
    ours = etag.removeprefix("W/")
    return any(tag.strip().removeprefix("W/") == ours for tag in header.split(","))


TOO_COSTLY_KEPT = 4096   # stills remembered as stopped at their deadline (oldest out)
TOO_COSTLY_S = 600.0     # ... for this long (a still stopped under a load that has passed may fit later)


def _over_budget(c: cost.Cost, settings: Settings, what: str,
                 stopped_at: float | None = None) -> RequestValidationError | None:
    """A 422 naming what to reduce, when `c` is beyond the still budgets, or when this
    still was stopped at its deadline of `stopped_at` s before (it would be again: asking
    once more must not cost another worker)."""
    reduce = ("Reduce what costs most: " + "; ".join(f"{k} ~{c.parts[k]:.1f} s" for k in c.biggest())
              + " (fewer or cheaper layers, fewer volume samples, a larger effects.fog_scale, or fewer pixels)")
    if stopped_at is not None:
        return RequestValidationError([errors.error(
            ["body"], f"{what} was stopped at its deadline of {stopped_at:g} s when it was asked before "
            f"(estimated at {c.seconds:.1f} s), so it is refused. {reduce}", "cost")])
    if c.memory > settings.still_memory_mb << 20:
        return RequestValidationError([errors.error(
            ["body", "width"], f"{what} needs about {c.memory / 2**20:.0f} MiB of render targets; "
            f"this server allows {settings.still_memory_mb} MiB: reduce width*height", "cost")])
    if c.seconds > settings.still_budget_s:
        return RequestValidationError([errors.error(
            ["body"], f"{what} is estimated at {c.seconds:.1f} s of rendering; this server allows "
            f"{settings.still_budget_s:g} s. {reduce}", "cost")])
    return None


# a POST body over the server's limit is refused before it is parsed (service/limits.py)
TOO_LARGE = {"description": "the body is larger than this server accepts (FOGBANK_MAX_BODY_BYTES); "
                            "the error names the limit"}


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    state: dict[str, Any] = {}

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        sup = Supervisor(settings)
        state["workers"] = sup
        app.state.workers = sup   # reachable for tests and fault injection
        info = await sup.start()
        log.info("renderer: %s", info)
        state["cache"] = StillCache(settings.stills_cache_mb << 20)
        state["stills"] = 0            # renders of distinct stills under way
        state["still_slots"] = asyncio.Semaphore(settings.max_stills)
        state["flights"] = {}          # ETag -> the task rendering it (single flight)
        state["too_costly"] = OrderedDict()   # ETags of stills stopped at their deadline (refused after)
        state["streamer"] = Streamer(sup, frames_per_worker=settings.frames_per_worker, settings=settings)
        state["streamer"].start()
        app.state.streamer = state["streamer"]   # reachable for tests
        state["ready"] = True
        yield
        state["ready"] = False
        sup.draining = True
        await state["streamer"].stop()
        await sup.stop()

    app = FastAPI(title="fogbank", version=__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="Analytic fog over a 3D scene, rendered on the server. "
                              "Every look is a URL: the same query works on the page and on "
                              "/api/still.png.")
    app.state.drain = lambda: state.update(draining=True)

    def custom_openapi():
        if app.openapi_schema is None:
            app.openapi_schema = openapi.build(app)
        return app.openapi_schema
    app.openapi = custom_openapi

    @app.exception_handler(RequestValidationError)
    async def _422(request: Request, exc: RequestValidationError):
        return JSONResponse(errors.body(exc.errors()), status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException):
        if exc.status_code == 400 and "parsing the body" in str(exc.detail):
            # a body that is not JSON (or not UTF-8): bad input like any other, 422
            return JSONResponse(errors.body([errors.error(["body"], "the body is not valid JSON",
                                                          "json_invalid")]), status_code=422)
        return JSONResponse({"detail": exc.detail}, status_code=exc.status_code,
                            headers=getattr(exc, "headers", None))

    async def _job(slot, fn, *args, deadline: float, remember: str | None = None, queue_s: float | None = None):
        """A worker job for a request; worker trouble becomes 503 + Retry-After (or the
        job's own error, 500, for a fault in the renderer's code). `remember`: the key under
        which a job that kept its worker busy to the deadline is kept in too_costly."""
        try:
            return await state["workers"].call(slot, fn, *args, deadline=deadline, queue_s=queue_s)
        except WorkerError as exc:
            metrics.ERRORS.labels("busy" if exc.status == 503 else "render").inc()
            msg = str(exc)
            if remember and isinstance(exc, DeadlineExceeded) and exc.stalled is False:
                costly = state["too_costly"]   # only a worker seen busy to the end blames the look
                costly.pop(remember, None)
                costly[remember] = (deadline, asyncio.get_running_loop().time())
                while len(costly) > TOO_COSTLY_KEPT:
                    costly.popitem(last=False)
                msg += "; asked again, it is refused (422): make it cheaper"
            raise HTTPException(exc.status, msg, headers={"Retry-After": str(exc.retry_after)}) from None
        except Exception as exc:  # noqa: BLE001 - a renderer fault fails this request only
            metrics.ERRORS.labels("render").inc()
            log.error("render failed", extra={"error": f"{type(exc).__name__}: {exc}"})
            raise HTTPException(500, f"render failed ({type(exc).__name__}): {exc}") from None

    def _slot_for(seconds: float):
        sup: Supervisor = state["workers"]
        if sup.batch is None or seconds <= settings.interactive_cost_s:
            return sup.interactive.least_loaded()
        return sup.batch.least_loaded()

    def _route(still: StillParams, fmt: str):
        """The worker for a still and its cost there: the interactive one when it is cheap
        there (its fog program already compiled counts), else a batch one."""
        sup: Supervisor = state["workers"]
        key = cost.program_key(still)
        fast = sup.interactive.least_loaded()
        c = cost.estimate(still, fmt=fmt, scale=settings.cost_scale, compiled=key in fast.compiled)
        if sup.batch is None or c.seconds <= settings.interactive_cost_s:
            return fast, c
        slot = sup.batch.least_loaded()
        return slot, cost.estimate(still, fmt=fmt, scale=settings.cost_scale, compiled=key in slot.compiled)

    async def _still(still: StillParams, fmt: str, request: Request, loc: str) -> Response:
        info = state["workers"].info
        query = encode_url(still)
        key = f"{__version__}|{info.get('renderer')}|{fmt}|{query}"
        etag = '"' + hashlib.sha256(key.encode()).hexdigest()[:32] + '"'
        # the look's link, compact when long: a readable one of a long look outgrew what a
        # proxy buffers for a response head (nginx, 4k by default: every still of a look
        # over ~4k characters was its 502, "no fogbank replica answered")
        headers = {"ETag": etag, "Cache-Control": "public, max-age=3600", "X-Fogbank-Query": shareable(query)}
        if none_match(request.headers.get("if-none-match"), etag):
            return Response(status_code=304, headers=headers)
        cached = state["cache"].get(etag)
        if cached is not None:
            return Response(cached, media_type=MEDIA_TYPES[fmt], headers=headers)
        flights: dict[str, asyncio.Task] = state["flights"]
        flight = flights.get(etag)
        if flight is None:   # the first ask for this still: checked, then rendered in a task of its own
            slot, c = _route(still, fmt)
            refusal = _over_budget(c, settings, "this still", _stopped_at(etag))
            if refusal is not None:
                metrics.ERRORS.labels("cost").inc()
                raise RequestValidationError([dict(e, loc=[loc, *e["loc"][1:]]) for e in refusal.errors()])
            # every distinct still in flight, rendering or waiting for a place: a task that
            # ends in any way (cancelled before its first step too) leaves flights
            if len(flights) >= settings.max_stills + settings.max_queued_stills:
                metrics.ERRORS.labels("busy").inc()
                raise HTTPException(503, f"{settings.max_stills} stills are rendering and "
                                    f"{settings.max_queued_stills} wait (FOGBANK_MAX_QUEUED_STILLS); retry shortly",
                                    headers={"Retry-After": "2"})
            flight = asyncio.get_running_loop().create_task(_render_still(still, fmt, etag))
            flights[etag] = flight
            flight.add_done_callback(lambda t, k=etag: (flights.pop(k, None), t.cancelled() or t.exception()))
        else:
            metrics.COALESCED.inc()
        # every asker of one still awaits its one render (single flight); shielded, so that
        # an asker who leaves does not cancel it for the others
        out = await asyncio.shield(flight)
        headers["Server-Timing"] = f'render;dur={out["render_ms"]:.1f}, encode;dur={out["encode_ms"]:.1f}'
        return Response(out["data"], media_type=MEDIA_TYPES[fmt], headers=headers)

    def _stopped_at(etag: str) -> float | None:
        """The deadline a still was stopped at within TOO_COSTLY_S (else None)."""
        got = state["too_costly"].get(etag)
        if got is None:
            return None
        if asyncio.get_running_loop().time() - got[1] > TOO_COSTLY_S:
            del state["too_costly"][etag]
            return None
        return got[0]

    async def _render_still(still: StillParams, fmt: str, etag: str) -> dict:
        """One distinct still: a place among max_stills, then its worker job, waiting for
        both at most queue_timeout_s in all (so that every still is answered within
        queue_timeout_s + render_timeout_s: the proxy's read timeout is set above that,
        docker/nginx/fogbank.conf); the result cached. It is in flights already."""
        t0 = asyncio.get_running_loop().time()
        try:
            await asyncio.wait_for(state["still_slots"].acquire(), settings.queue_timeout_s)
        except asyncio.TimeoutError:
            metrics.ERRORS.labels("busy").inc()
            raise HTTPException(503, f"this still waited {settings.queue_timeout_s:g} s for one of "
                                f"{settings.max_stills} places to render; retry shortly",
                                headers={"Retry-After": "5"}) from None
        state["stills"] += 1
        try:
            waited = asyncio.get_running_loop().time() - t0
            # its worker chosen now, not when it was asked: stills that waited together for
            # places all saw the same least loaded worker then
            slot, _ = _route(still, fmt)
            out = await _job(slot, worker.still, still, fmt, deadline=settings.render_timeout_s, remember=etag,
                             queue_s=max(0.5, settings.queue_timeout_s - waited))
            slot.drew(cost.program_key(still))
        finally:
            state["stills"] -= 1
            state["still_slots"].release()
        metrics.STILLS.labels(fmt).inc()
        metrics.RENDER_MS.observe(out["render_ms"])
        state["cache"].put(etag, out["data"])
        return out

    @app.get("/api/still.{fmt}", summary="Render a still from URL params",
             responses={200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
                        304: {"description": "not modified (If-None-Match)"},
                        422: {"description": "a param is invalid, or the look costs more than this "
                                             "server renders; the body names what to change"},
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
        return await _still(still, fmt, request, "query")

    @app.post("/api/still", summary="Render a still from JSON params",
              responses={200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
                         413: TOO_LARGE,
                         422: {"description": "a param is invalid, or the look costs more than this "
                                              "server renders; the body names what to change"},
                         503: {"description": "busy or slow renderer; see Retry-After"}},
              openapi_extra={"requestBody": {"required": False, "content": {"application/json": {
                  "schema": {"type": "object"}}}}})   # the StillParams schema: see openapi.py
    async def still_post(request: Request, format: Literal["png", "jpg", "webp"] = "png"):
        raw = await request.body()
        try:
            body = json.loads(raw) if raw.strip() else {}
        except (ValueError, RecursionError) as exc:
            raise RequestValidationError([errors.error(["body"], f"malformed JSON: {exc}",
                                                       "json_invalid")]) from None
        return await _still(resolve(body), format, request, "body")

    def rays_of(req: TransmittanceRequest, light: bool = False):
        """A rays request's look and (origins, unit directions, lengths, times, cost);
        `light`: costed as the light endpoint's."""
        fog = resolve(req.params, FogParams, ("body", "params"))
        O = np.array([r.origin for r in req.rays], dtype=np.float64)
        W = np.array([r.direction for r in req.rays], dtype=np.float64)
        big = np.abs(W).max(axis=1)
        bad = np.nonzero(~(big > 0))[0]
        if len(bad):
            raise RequestValidationError([errors.error(["body", "rays", int(bad[0]), "direction"],
                                                       "direction must be a non-zero vector",
                                                       "value_error")])
        W = W / big[:, None]                  # scaled first: tiny vectors do not underflow
        W = W / np.linalg.norm(W, axis=1)[:, None]
        D = np.array([r.length for r in req.rays])
        Tm = np.array([r.time for r in req.rays])
        groups = len(np.unique(np.column_stack([Tm, O]), axis=0))
        c = cost.transmittance_seconds(fog, len(D), len(np.unique(Tm)), settings.cost_scale, groups, light)
        if c.seconds > settings.still_budget_s:
            metrics.ERRORS.labels("cost").inc()
            raise RequestValidationError([errors.error(
                ["body", "rays"], f"this request is estimated at {c.seconds:.1f} s (each distinct "
                "ray time simulates every particle layer, each distinct origin and time is one "
                f"draw); this server allows {settings.still_budget_s:g} s: use fewer distinct "
                "times, origins or particles", "cost")])
        return fog, O, W, D, Tm, c

    @app.post("/api/transmittance", response_model=TransmittanceResponse,
              responses={413: TOO_LARGE,
                         422: {"description": "bad rays or params, or more particle simulation than "
                                              "this server does per request"},
                         503: {"description": "busy or slow renderer; see Retry-After"}},
              summary="Transmittance of rays through the fog, by the frame's own GLSL")
    async def transmittance(req: TransmittanceRequest):
        fog, O, W, D, Tm, c = rays_of(req)
        out = await _job(_slot_for(c.seconds), worker.transmittance, fog, O, W, D, Tm,
                         deadline=settings.render_timeout_s)
        return {"transmittance": [float(x) for x in out["T"]],
                "renderer": state["workers"].info.get("renderer", "")}

    @app.post("/api/light", response_model=LightResponse,
              responses={413: TOO_LARGE,
                         422: {"description": "bad rays or params, or more particle simulation than "
                                              "this server does per request"},
                         503: {"description": "busy or slow renderer; see Retry-After"}},
              summary="The light the fog scatters along rays (single scattering), by the GLSL that lights "
                      "the frames: each ray marched in 128 slices, the fog toward the sun by the closed forms "
                      "(effects.lit), the scene's shadows from its shadow map (effects.shafts)")
    async def light(req: TransmittanceRequest):
        fog, O, W, D, Tm, c = rays_of(req, light=True)
        out = await _job(_slot_for(c.seconds), worker.light, fog, O, W, D, Tm,
                         deadline=settings.render_timeout_s)
        return {"transmittance": [float(x) for x in out["T"]], "in_scattered": [float(x) for x in out["J"]],
                "medium_transmittance": [float(x) for x in out["T_medium"]],
                "light": [[float(v) for v in row] for row in out["light"]],
                "renderer": state["workers"].info.get("renderer", "")}

    suggest_lock = asyncio.Lock()

    @app.post("/api/layers/suggest", response_model=dict[str, Any],
              responses={413: TOO_LARGE, 422: {"description": "an unknown kind, or bad params"}},
              summary="A new layer for a look: its kind's defaults, placed in front of the camera "
                      "and thinned so that it cannot white out the view")
    async def suggest(req: SuggestRequest):
        fog = resolve(req.params, FogParams, ("body", "params"))
        # float64 numpy on a thread (a noise layer may bake its tile), one at a time: the
        # loop stays free and a burst of requests takes one core at most
        async with suggest_lock:
            return await asyncio.to_thread(suggest_layer, req.kind, fog)

    @app.post("/api/plot/ray", response_model=dict[str, Any], responses={413: TOO_LARGE},
              summary="The ray under a pixel, in float64: each layer's density along it and T(s)")
    async def ray_plot(req: RayPlotRequest):
        for name, v, side in (("x", req.x, req.width), ("y", req.y, req.height)):
            if v >= side:
                raise RequestValidationError([errors.error(
                    ["body", name], f"{name} = {v:g} is outside the {req.width}x{req.height} view "
                    f"(0 <= {name} < {side})", "value_error")])
        fog = resolve(req.params, FogParams, ("body", "params"))
        c = cost.plot_seconds(fog, settings.cost_scale)
        if c.seconds > PLOT_BUDGET_S:
            metrics.ERRORS.labels("cost").inc()
            raise RequestValidationError([errors.error(
                ["body", "params"], f"this look's ray plot is estimated at {c.seconds:.1f} s; a plot "
                f"follows the cursor, so it may take {PLOT_BUDGET_S:g} s: " + "; ".join(
                    f"{k} ~{c.parts[k]:.1f} s" for k in c.biggest()) +
                " (fewer particles or longer simulation steps, a smaller or already baked noise tile)",
                "cost")])
        # float64 numpy in a worker process (its time, its deadline), never the web process
        out = await _job(_slot_for(c.seconds), worker.plot_ray, fog, req.x, req.y, req.width, req.height,
                         deadline=settings.render_timeout_s)
        return out["plot"]

    @app.post("/api/layers/profile", response_model=dict[str, Any], responses={413: TOO_LARGE},
              summary="A polynomial or cosine layer's density along its axis, the points that shape "
                      "it, the coefficients they give, and the rules a shape breaks (Biri's Fig. 2 editor)")
    async def layer_profile(req: LayerProfileRequest):
        try:
            return profile(req.layer, req.points)
        except ValueError as exc:
            raise RequestValidationError([errors.error(("body", "points"), str(exc), "value_error")]) from None

    @app.get("/api/schema", summary="JSON Schema of the params (ranges, slider steps, units)")
    async def schema():
        return StillParams.model_json_schema()

    @app.get("/api/presets", summary="The named looks")
    async def presets_list():
        out = []
        for name, p in P.presets().items():
            fog = FogParams.model_validate(P.preset_dict(name))
            out.append({"name": name, "title": p["title"], "description": p["description"],
                        "source": p["source"],
                        "query": encode_url(fog), "params": P.preset_dict(name)})
        return out

    @app.get("/healthz",
                   summary="Liveness: 200 while the interactive lane (the streams' workers) can render: a "
                           "worker of it rendered within liveness_s, or runs a job without stalling",
                   responses={503: {"description": "the interactive lane cannot render: restart me"}})
    async def healthz():
        sup: Supervisor | None = state.get("workers")
        if sup is None:
            return JSONResponse({"status": "starting"}, status_code=503)
        live, age = sup.live()
        info = sup.info
        body = {"status": "ok" if live else "failing", "renderer": info.get("renderer"),
                "gl_version": info.get("version"), "last_render_s": round(age, 3),
                "lanes": sup.lanes_live(), "queue": sup.queue_depth(), "workers": sup.status()}
        return JSONResponse(body, status_code=200 if live else 503)

    @app.get("/readyz",
                   summary="Readiness: 200 when this replica takes new work",
                   responses={503: {"description": "starting, draining, busy or failing"}})
    async def readyz():
        sup: Supervisor | None = state.get("workers")
        streamer = state.get("streamer")
        if sup is None or not state.get("ready"):
            return JSONResponse({"status": "starting"}, status_code=503)
        if sup.draining or state.get("draining"):
            return JSONResponse({"status": "draining"}, status_code=503)
        down = [name for name, ok in sup.lanes_live().items() if not ok]
        if down:   # a lane that cannot render: stills or streams sent here would wait on it
            return JSONResponse({"status": "failing", "reason": f"the {' and '.join(down)} lane cannot render",
                                 "lanes": sup.lanes_live()}, status_code=503)
        if len(streamer.clients) >= settings.max_sessions:
            return JSONResponse({"status": "busy", "reason": "sessions full"}, status_code=503)
        if state["stills"] >= settings.max_stills:
            return JSONResponse({"status": "busy", "reason": "stills full"}, status_code=503)
        return {"status": "ready", "sessions": len(streamer.clients), "stills": state["stills"]}

    for path, fn in (("/healthz", healthz), ("/readyz", readyz)):
        app.add_api_route(path, fn, methods=["HEAD"], include_in_schema=False)

    @app.websocket("/ws")
    async def ws(websocket: WebSocket):
        if not origin_allowed(websocket.headers.get("origin"), websocket.headers.get("host"),
                              settings.allowed_origins, websocket.url.scheme):
            metrics.ERRORS.labels("origin").inc()
            await websocket.close(code=1008, reason="origin not allowed")
            return
        await websocket_endpoint(websocket, state["streamer"], state["workers"].info)

    @app.get("/metrics", include_in_schema=False)
    async def metrics_endpoint():
        sup: Supervisor | None = state.get("workers")
        metrics.QUEUE.set(sup.queue_depth() if sup else 0)
        metrics.SESSIONS.set(len(state["streamer"].clients) if "streamer" in state else 0)
        if sup:
            metrics.TREE_RSS.set(sup.tree_rss())
        return Response(metrics.render(), media_type=metrics.CONTENT_TYPE)

    @app.api_route("/", methods=["GET", "HEAD"], include_in_schema=False)
    async def index():
        return FileResponse(STATIC_DIR / "index.html")

    @app.api_route("/docs", methods=["GET", "HEAD"], include_in_schema=False)
    async def docs():
        """Swagger UI from assets served here (no CDN; the page's CSP holds)."""
        return FileResponse(STATIC_DIR / "docs.html")

    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    app.mount("/docs-assets", StaticFiles(directory=SWAGGER_DIR), name="docs-assets")
    app.add_middleware(SecurityHeaders)
    app.add_middleware(HostCheck, allowed=allowed_hosts(settings.allowed_hosts, settings.host))
    app.add_middleware(RequestLimits, max_body=settings.max_body_bytes, max_url=settings.max_url_bytes,
                       max_headers=settings.max_headers, max_header_bytes=settings.max_header_bytes)
    return app
