"""One streaming client's state, with no GL and no socket in it: the look, the clock, the
preferred view, frames in flight, and when the next frame is due.

Latest-wins: a session holds only its current state; a frame is a snapshot of it taken
when the scheduler starts that frame, so changes that arrive meanwhile are never queued
behind it. At most MAX_IN_FLIGHT frames are unacknowledged or being made.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from fogbank.model import errors
from fogbank.model import presets as P
from fogbank.model.params import FogParams, StillParams
from fogbank.stream.protocol import (AckMsg, CameraMsg, InteractMsg, ParamsMsg, PlayMsg, QueryMsg, SeekMsg,
                       SpeedMsg, ViewMsg)
from fogbank.model.urlstate import URLError, decode_lenient, encode, view_state, view_suffix

MAX_IN_FLIGHT = 2
INPUT_SETTLE_S = 0.25     # after the last input, this long until the full-quality refinement
VIEW_WAIT_S = 0.3         # a new session waits this long for its client's view size
PREVIEW_QUALITY = 60      # JPEG quality while the user drags
# A preview's render budget: a look whose previews take longer is previewed smaller (a
# costly look blurs while it is dragged instead of dropping the page's frame rate); the
# full-quality frame after input stops is always the view's size (Session.measured).
PREVIEW_BUDGET_MS = 60.0
PREVIEW_SCALES = (1.0, 0.75, 0.5, 0.35, 0.25)   # of the view's side: few sizes, few cached targets
PREVIEW_MIN_SIDE = 64
PREVIEW_COST_TTL_S = 2.0   # a scale's measured cost is trusted this long (the look may change)


@dataclass
class FrameJob:
    """What one frame is made from (a snapshot of the session)."""
    frame: int
    version: int
    still: StillParams
    msaa: bool
    quality: int
    full: bool
    playing: bool
    show: str = "shaded"   # or a view that teaches (render/teach.py), with its layer
    layer: int = 0
    scale: float = 1.0     # a preview's share of the view's side


class Session:
    def __init__(self, sid: str, now: float, query: str = ""):
        self.id = sid
        self.view = ViewMsg(type="view")
        self.view_known = False   # frames wait for the client's size (briefly)
        self.created = now
        self.version = 0
        self.frame = 0            # id of the last frame started
        self.acked = 0            # highest frame id acknowledged
        self.making = 0           # frames started but not yet sent
        self.sent = 0             # id of the last frame sent
        self.last_start = -math.inf
        self.last_input = -math.inf
        self.interacting = False
        self.dirty = True         # the look changed since the last frame
        self.last_full = True     # the last frame was a full-quality one
        self.playing = True
        self.speed = 1.0
        self.stalled = -1         # the version whose frame passed its deadline
        self.preview_scale = 1.0  # of the view's side, for previews
        self.preview_costs: dict[float, tuple[float, float]] = {}   # scale -> (ms, when measured)
        self.fog = FogParams.model_validate(P.preset_dict("default"))
        self._base_sim = self.fog.time
        self._base_wall = now
        if query:
            self.apply(QueryMsg(type="query", query=query), now)

    # ------------------------------------------------------------ clock

    def sim_time(self, now: float) -> float:
        if not self.playing:
            return self._base_sim
        return max(0.0, self._base_sim + (now - self._base_wall) * self.speed)

    def _rebase(self, now: float, sim: float) -> None:
        self._base_sim, self._base_wall = max(0.0, sim), now

    # ------------------------------------------------------------ messages

    def state(self, now: float) -> dict[str, Any]:
        return {"type": "state", "version": self.version,
                "query": encode(self.fog) + view_suffix(self.playing, self.speed),
                "params": self.fog.model_dump(mode="json"), "playing": self.playing,
                "speed": self.speed, "time": self.sim_time(now), "view": self.view.model_dump()}

    def _set_fog(self, fog: FogParams, now: float, *, input_: bool = True) -> None:
        if fog.time != self.fog.time:   # a new time in the look is a seek
            self._rebase(now, fog.time)
        self.fog = fog
        self.version += 1
        self.dirty = True
        if input_:
            self.last_input = now

    def apply(self, msg, now: float) -> list[dict[str, Any]]:
        """Apply one message; returns the messages to send back (state or error). A bad
        message changes nothing."""
        try:
            if isinstance(msg, QueryMsg):
                # a link with bad parts keeps the rest of its look; the error names the
                # parts left out ("kept": the look shown is the rest)
                try:
                    fog, bad = decode_lenient(msg.query.lstrip("?"), FogParams)
                except URLError as exc:
                    return [{"type": "error", "detail": exc.errors, "msg": str(exc)}]
                self._set_fog(fog, now, input_=False)
                view = view_state(msg.query.lstrip("?"))
                self.playing = view.get("playing", True)
                self.speed = view.get("speed", 1.0)
                self._rebase(now, self.fog.time)
                out = [self.state(now)]
                if bad:
                    out.append({"type": "error", "detail": bad, "kept": True,
                                "msg": "; ".join(f"{e['loc'][-1]} ({e['msg']})" for e in bad)})
                return out
            if isinstance(msg, (ParamsMsg, CameraMsg)):
                patch = msg.params if isinstance(msg, ParamsMsg) else {"camera": msg.camera}
                base = None if getattr(msg, "replace", False) else self.fog.model_dump(mode="json")
                fog = P.patched(patch, base)
                self._set_fog(fog, now)
                return [self.state(now)]
        except ValidationError as exc:
            prefix = ["params"] if isinstance(msg, ParamsMsg) else []
            errs = [errors.clean(e) for e in errors.from_validation(exc, prefix)]
            return [{"type": "error", "detail": errs, "msg": errors.summary(errs)}]
        if isinstance(msg, PlayMsg):
            if msg.playing != self.playing:
                t = self.sim_time(now)
                self.playing = msg.playing
                self._rebase(now, t)
                if not msg.playing:   # the URL keeps the paused time
                    self.fog = self.fog.model_copy(update={"time": round(t, 3)})
                    self._base_sim = self.fog.time
                    self.version += 1
                self.dirty = True
            return [self.state(now)]
        if isinstance(msg, SpeedMsg):
            self._rebase(now, self.sim_time(now))
            self.speed = msg.speed
            return [self.state(now)]
        if isinstance(msg, SeekMsg):
            self._rebase(now, msg.time)
            self.fog = self.fog.model_copy(update={"time": msg.time})
            self.version += 1
            self.dirty = True
            self.last_input = now
            return [self.state(now)]
        if isinstance(msg, ViewMsg):
            self.view = msg
            self.view_known = True
            self.dirty = True
            n = len(self.fog.layers)
            if msg.show == "optical_depth" and msg.layer >= n:
                # said once; the frames show the look until a layer of that index exists
                return [{"type": "error", "loc": ["message", "layer"],
                         "msg": f"layer {msg.layer} does not exist: this look has {n} layer(s)"
                                + (f", 0 to {n - 1}" if n else "") + "; the frames show the look meanwhile"}]
            return []
        if isinstance(msg, InteractMsg):
            self.interacting = msg.active
            self.last_input = now
            return []
        if isinstance(msg, AckMsg):
            if msg.frame <= self.sent:
                self.acked = max(self.acked, msg.frame)
            return []
        return [{"type": "error", "msg": f"unhandled message {type(msg).__name__}"}]

    # ------------------------------------------------------------ scheduling

    def in_flight(self) -> int:
        return (self.sent - self.acked) + self.making

    def previewing(self, now: float) -> bool:
        return self.interacting or now - self.last_input < INPUT_SETTLE_S

    def wants_frame(self, now: float) -> bool:
        """Something new to show: time runs, the look changed, or a refinement is owed
        (never while the look whose frame was stopped at its deadline is unchanged)."""
        if self.stalled == self.version:
            return False
        return self.playing or self.dirty or (not self.last_full and not self.previewing(now))

    def next_due(self, now: float) -> float | None:
        """When the next frame may start (None: nothing to send until something changes)."""
        if self.in_flight() >= MAX_IN_FLIGHT:
            return None   # an ack or a finished frame wakes the scheduler
        if not self.view_known and now < self.created + VIEW_WAIT_S:
            return self.created + VIEW_WAIT_S   # no frame at a size the client did not ask for
        if not self.wants_frame(now):
            if not self.last_full and self.previewing(now):
                return self.last_input + INPUT_SETTLE_S   # the refinement, once input settles
            return None
        return max(now, self.last_start + 1.0 / self.view.fps)

    def start_frame(self, now: float) -> FrameJob:
        preview = self.previewing(now)
        v = self.view
        fog = self.fog
        scale = fog.effects.fog_scale
        if preview:   # cheaper while dragging: coarser fog, no MSAA, lower JPEG quality
            scale = max(scale, 2 if v.width * v.height <= 640 * 360 else 4)
        eff = fog.effects.model_copy(update={"fog_scale": scale})
        width, height = v.width, v.height
        if preview and self.preview_scale < 1.0:
            # one scale for both sides (the view's shape kept), its short side at least
            # PREVIEW_MIN_SIDE (or the view's own, if shorter)
            k = min(1.0, max(self.preview_scale, PREVIEW_MIN_SIDE / min(v.width, v.height)))
            width, height = (max(2, 2 * round(side * k / 2)) for side in (v.width, v.height))
        still = StillParams.model_construct(**{**dict(fog), "effects": eff, "time": self.sim_time(now),
                                               "width": width, "height": height})
        self.frame += 1
        self.making += 1
        self.last_start = now
        self.dirty = False
        self.last_full = not preview
        return FrameJob(self.frame, self.version, still, msaa=not preview,
                        quality=min(v.quality, PREVIEW_QUALITY) if preview else v.quality,
                        full=not preview, playing=self.playing, show=self.showing(), layer=v.layer,
                        scale=self.preview_scale if preview else 1.0)

    def showing(self) -> str:
        """What the frames show: the view's choice, or the look while it asks for the
        optical depth of a layer the look does not have (no frame fails on it)."""
        v = self.view
        if v.show == "optical_depth" and v.layer >= len(self.fog.layers):
            return "shaded"
        return v.show

    def pause(self, now: float) -> None:
        """Stop the clock and make no frame until the look changes (its frame was too
        costly: trying again would only fail again)."""
        if self.playing:
            self.apply(PlayMsg(type="play", playing=False), now)
        self.stalled = self.version
        self.dirty = False

    def measured(self, job: FrameJob, render_ms: float, now: float) -> None:
        """A frame's render time. Previews climb PREVIEW_SCALES by what they cost: a
        preview over PREVIEW_BUDGET_MS makes the next one a step smaller; one well under
        it (a fifth to spare) a step larger, unless that size was measured over the
        budget within PREVIEW_COST_TTL_S. Costs are measured, not modelled: a frame's
        fixed costs (shadow map, sky, particles) do not shrink with its pixels, so a step
        down that did not pay (the size above cost at most a quarter more) is taken back,
        and one known not to pay is not taken."""
        if job.full:
            return
        prev = self.preview_costs.get(job.scale)
        ms = render_ms if prev is None or now - prev[1] > PREVIEW_COST_TTL_S else 0.5 * (prev[0] + render_ms)
        self.preview_costs[job.scale] = (ms, now)
        if job.scale != self.preview_scale:
            return   # a frame of an earlier step: recorded, no step taken
        i = PREVIEW_SCALES.index(self.preview_scale)
        fresh = lambda k: (c := self.preview_costs.get(k)) is not None and now - c[1] <= PREVIEW_COST_TTL_S  # noqa: E731
        if i > 0 and fresh(PREVIEW_SCALES[i - 1]) and self.preview_costs[PREVIEW_SCALES[i - 1]][0] <= 1.25 * ms:
            # the step down did not pay (the cost is fixed, not in the pixels): back up
            self.preview_scale = PREVIEW_SCALES[i - 1]
        elif ms > PREVIEW_BUDGET_MS and i + 1 < len(PREVIEW_SCALES):
            down = PREVIEW_SCALES[i + 1]
            # no step down that did not pay: a look whose cost is fixed (not in its
            # pixels) keeps its sharper preview
            if not (fresh(down) and self.preview_costs[down][0] > 0.8 * ms):
                self.preview_scale = down
        elif ms < 0.8 * PREVIEW_BUDGET_MS and i > 0:
            up = PREVIEW_SCALES[i - 1]
            if not fresh(up) or self.preview_costs[up][0] <= PREVIEW_BUDGET_MS:
                self.preview_scale = up

    def frame_done(self, job: FrameJob, sent: bool) -> None:
        """A frame was sent (or dropped: failed, stale, or the client left)."""
        self.making -= 1
        if sent:
            self.sent = max(self.sent, job.frame)
