"""One streaming client's state, with no GL and no socket in it: the look, the clock, the
preferred view, frames in flight, and when the next frame is due.

Latest-wins: a session holds only its current state; a frame is a snapshot of it taken
when the scheduler starts that frame, so changes that arrive meanwhile are never queued
behind it. At most window() frames are unacknowledged or being made: MAX_IN_FLIGHT, and
those one round trip of its link holds (stream/link.py pipe_frames).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from fogbank.kinds.packing import split_by_time, variant
from fogbank.model import errors
from fogbank.model import presets as P
from fogbank.model.params import FogParams, StillParams
from fogbank.stream.link import FrameFit, Link
from fogbank.stream.protocol import (AckMsg, CameraMsg, InteractMsg, ParamsMsg, PlayMsg, PongMsg, QueryMsg, SeekMsg,
                       SpeedMsg, ViewMsg)
from fogbank.model.urlstate import URLError, decode_lenient, encode, encode_field, view_state, view_suffix

MAX_IN_FLIGHT = 2
# a video stream's bits a second at 1280x720 (issue 34's target: the default look playing
# at 30 fps in at most 1.5 Mbit/s at the SSIM of JPEG q80; VP9 reaches it at 1 Mbit/s:
# `fogbank bench-codecs`), as pixels^0.75 otherwise, within VIDEO_BPS_RANGE, and at most
# HEADROOM of the link's measured rate while the link limits the stream
VIDEO_BPS_720P = 1.45e6   # 1.48 Mbit/s, its half-octave step
VIDEO_BPS_RANGE = (150e3, 6e6)


def video_bitrate(pixels: int, link_bps: float | None) -> int:
    """The bitrate of a video stream of `pixels` a frame on a link of `link_bps`."""
    from fogbank.stream.link import HEADROOM
    lo, hi = VIDEO_BPS_RANGE
    # pixels^0.75: a smaller frame's detail is coarser, and takes more bits a pixel (at
    # 480x270, bits in proportion to pixels gave SSIM 0.989 to JPEG q80's 0.991)
    bps = min(hi, max(lo, VIDEO_BPS_720P * (pixels / (1280 * 720)) ** 0.75))
    if link_bps:
        bps = max(lo, min(bps, HEADROOM * link_bps))
    # in steps of half an octave: a new bitrate is a new encoder and a keyframe (libvpx
    # ignores one changed in place), so a rate that wanders within a step changes nothing
    return int(2 ** (round(2 * math.log2(bps)) / 2))
INPUT_SETTLE_S = 0.25     # after the last input, this long until the full-quality refinement
VIEW_WAIT_S = 0.3         # a new session waits this long for its client's view size
PREVIEW_QUALITY = 60      # JPEG quality while the user drags
# A preview's render budget (preview_budget_ms): a look whose previews take longer is
# previewed smaller (a costly look blurs while it is dragged instead of dropping the page's
# frame rate); the frame after input stops has budgets of its own (REFINE_BUDGET_MS,
# PLAY_BUDGET_MS). It is what a frame may take for a drag to keep its frame rate: the
# frame's interval less what follows the render (the JPEG, the pipe to the web process,
# the socket; PREVIEW_AFTER_MS, measured here with `fogbank bench` at 1280x720 and at
# 640x360 alike). The frame rate is issue 13's for the view's size: PREVIEW_FPS at
# 1280x720 and larger, PREVIEW_FPS_SMALL at 640x360 and smaller, geometric in the view's
# pixels between (32.5 fps at 960x540). At 60 ms, 720p previews were 640 px wide at 15-17
# fps. With 24 fps at every size, a 640x360 drag's previews were 320 px wide in some
# rounds of the benchmark (12-14 ms, 48-54 fps delivered) and 480 px in others (20-29 ms,
# 29-43 fps).
PREVIEW_FPS = 24.0
PREVIEW_FPS_SMALL = 50.0
PREVIEW_AFTER_MS = 7.0
PREVIEW_BUDGET_MS = 1000.0 / PREVIEW_FPS - PREVIEW_AFTER_MS   # at 1280x720 and larger
_LARGE, _SMALL = 1280 * 720, 640 * 360


def preview_budget_ms(width: int, height: int) -> float:
    """The render budget of a preview for a view of this size (PREVIEW_FPS..PREVIEW_FPS_SMALL)."""
    k = min(1.0, max(0.0, math.log(_LARGE / max(1, width * height)) / math.log(_LARGE / _SMALL)))
    return 1000.0 / (PREVIEW_FPS * (PREVIEW_FPS_SMALL / PREVIEW_FPS) ** k) - PREVIEW_AFTER_MS
# The previews' ladder, sharpest first: (share of the view's side, detail). Detail below 1
# takes that share of each volume-noise layer's samples per ray and of each particle
# layer's particles (_detailed), the costs a smaller picture does not shrink enough. Few
# sizes, few cached targets.
PREVIEW_RUNGS = ((1.0, 1.0), (0.75, 1.0), (0.5, 1.0), (0.35, 1.0), (0.25, 1.0), (0.25, 0.25), (0.25, 1 / 16))
PREVIEW_SCALES = tuple(dict.fromkeys(k for k, _ in PREVIEW_RUNGS))
PREVIEW_MIN_SIDE = 64
PREVIEW_COST_TTL_S = 2.0   # a rung's measured cost is trusted this long (the look may change)
# A new look whose estimated cost (workers/cost.py, scaled by what this session's previews
# measured against their estimates) differs this much from the last one's starts on the
# rung the estimate picks, not where the old look's measurements left the ladder: a look
# made costly in one step (16 layers of volume noise) would otherwise spend seconds on
# frames at the old size before the ladder came down.
PREVIEW_RECOST = 1.5
# A first preview is far over the budget past this many budgets (485 ms at 1280x720, 332 at
# 960x540, 182 at 640x360: preview_budget_ms): the default look's first preview,
# uncalibrated, is estimated at 176 ms at 960x540 and 291 ms at 1280x720 (measured 20-60
# ms; 256 and 371 ms before the scene pass's refit, workers/cost.py) and starts on the
# sharpest rung; at 1920x1080, 619 ms, it starts lower.
# The model's estimate is the least it is taken for here, calibrated or not: a session's
# ratio is measured on its full frames, and one below 1 made 16 layers of every kind start
# their drag at 960 px, 330 ms a frame.
PREVIEW_FIRST_OVER = 14.0
# The refinement after input stops is the full look unless its calibrated estimate is over
# this: then the sharpest of (no MSAA, then the preview rungs) that fits. A refinement is one
# frame no input can interrupt (GL draws are not cancelled), and the worker it runs on draws
# every other session's frames meanwhile: 16 layers of 128-sample volume noise at 960x540
# took past the 10 s frame deadline, and every slider moved meanwhile waited for it.
REFINE_BUDGET_MS = 2000.0
# While time runs, every frame after input stops is a full one, and the next input waits
# for the one in flight (GL draws are not cancelled): a slider touched as such a frame
# starts is shown after it and one preview (PREVIEW_BUDGET_MS). So those frames are held
# to this (calibrated, as above), which keeps that wait within the 250 ms target
# for one change, not only for most changes of a drag: at 300 ms, 16 layers of volume
# noise held a drag's first change for 390-450 ms. The scene pass the worker holds (the
# camera still) is not in the estimate. A new session's first frames, not yet calibrated,
# may be reduced: the default look at 960x540 is estimated at 298 ms with MSAA (measured
# 166), so its first frame is 960 px wide without MSAA (at 0.1 s), and the next,
# calibrated, the full look (at 0.3-0.4 s; at 1280x720 alike). Sessions that play or
# preview on one worker share it: their frames are drawn in turn, so an input waits for
# theirs too, and each session's frames are held to this over their number
# (Streamer.sharing). Four 1280x720 streams on one worker, two of whose scene passes its
# cache holds: the other two drew theirs with MSAA, 230 ms a frame, and each stream got
# 2.2 frames a second (7.7 shared).
PLAY_BUDGET_MS = 200.0
# While time runs over a still camera, a full frame asks its worker to hold the fog's
# time-invariant part with the scene pass (render/passes/fog.py), unless some layers move
# and the two programs the fog is then drawn in would be slow to compile (cost.jit_seconds
# of each; the default look's are estimated at 0.49 s, measured 90 ms): a held fog pays
# back in frames, and a compile of a costly look (16 layers of cosines, 0.8 s estimated)
# is a stall that every session on the worker waits for. A look where nothing moves holds
# its fog target itself and compiles nothing. Previews never ask: a look dragged changes
# at every few frames.
HOLD_COMPILE_S = 0.6
# A refinement level whose first frames (its scene pass and whole fog drawn) would take
# over the play budget is taken only after this long without input: a user who watches,
# not one who is about to drag (_refinement). 1920x1080's first frame with MSAA takes about
# 500 ms, its next ones 65.
QUIET_S = 2.0
# ... but not without bound: a level's first frames (its scene pass and whole fog drawn)
# may take at most this once quiet (or the whole budget where that is more: 2 s for a
# paused look), and at most SHARED_FIRST_MS while other sessions play or
# preview on the worker (a frame cannot be interrupted, and theirs wait for it). 16 layers
# of volume noise at 1920x1080 climbed while quiet to 1440 px, whose first two frames took
# 6.5 s each: a 640x360 stream on the same worker got 0.2 frames a second (issue 33)
QUIET_FIRST_MS = 1000.0
SHARED_FIRST_MS = 300.0
# A refinement level's measured ratio (Session.level_ratios) is trusted this long: a level
# measured costly is not drawn, so not measured again, and the sharper levels borrow its
# ratio; after this the session tries them again.
RATIO_TTL_S = 10.0
# A scene pass the worker let go (Session.scenes_lost) is taken as lost this long: the
# session may have left the sizes it could redraw it at, and the other sessions the worker.
LOST_S = 5.0


def _detailed(layer, detail: float):
    """A layer at a share of its cost for a preview rung: a volume-noise layer with that
    share of its samples per ray, a particle layer with that share of its particles drawn,
    each as much more opaque (the swarm's optical depth kept, its grain coarser; the swarm
    simulated is the layer's own, kinds/particles.py thinned); others as they are."""
    if layer.kind == "noise" and layer.mode == "volume":
        return layer.model_copy(update={"samples": max(1, math.ceil(layer.samples * detail))})
    if layer.kind == "particles":
        return layer.thinned(round(1.0 / detail))
    return layer


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
    rung: int = 0          # its rung of PREVIEW_RUNGS
    estimate_ms: float = 0.0   # its estimated render time (workers/cost.py, uncalibrated)
    reduced: bool = False  # a refinement below the look's quality (Session._refinement)
    hold_fog: bool = False  # the worker keeps the fog's time-invariant part (Session._holds_fog)
    scene_cached: bool = False  # its estimate took the worker to hold its scene pass (Session._scene_cached)
    level: int = 0         # its quality: Session._refinement's level (a preview's rung's)
    codec: str = "jpeg"    # or a video codec (render/video.py), with its bitrate and keyframe ask
    bitrate: int = 0
    keyframe: bool = False



def _shown(show: str, layer: int) -> tuple[str, int]:
    """What a view shows, for its costs: the layer matters to the optical depth only."""
    return (show, layer if show == "optical_depth" else 0)

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
        self.link = Link()        # the viewer's link, from its acks (stream/link.py)
        self.need_key = False     # the next video frame must be a keyframe (one was dropped)
        # the codecs every viewer of a live session decodes (stream/live.py; None: no viewers)
        self.decoders: frozenset[str] | None = None
        self.fit = FrameFit()     # the quality and size of frame it carries
        self.last_start = -math.inf
        self.not_before = -math.inf   # no frame before this (redo's `after`)
        self.last_input = -math.inf
        self.interacting = False
        self.dirty = True         # the look changed since the last frame
        self.last_full = True     # the last frame was a full-quality one
        self.playing = True
        self.speed = 1.0
        self.stalled = -1         # the version whose frame passed its deadline
        self.preview_rung = 0     # of PREVIEW_RUNGS, for previews
        self.preview_costs: dict[int, tuple[float, float]] = {}   # rung -> (ms, when measured)
        self.last_ms: float | None = None   # the last frame's render time (not one that compiled)
        self.last_level: int | None = None   # the refinement level last_ms measured (None: a preview)
        self.cost_ratio = 1.0     # measured / estimated render time of this session's frames
        self.calibrated = False   # cost_ratio is measured, not the prior 1.0
        self.refine_level = 0     # the refinement's last quality (Session._refinement)
        # a sharper refinement is owed: the last full frame's level was below the best the
        # calibrated estimates fit only because that level was not measured yet (it is
        # climbed a level a frame); owed once that frame is measured (`_climb`: when drawn)
        self.refine_owed = False
        self._climb = False
        # measured / estimated of the full frames at each refinement level, smoothed: the cost
        # model's error differs by size (a look's fixed costs against its pixels)
        self.level_ratios: dict[int, tuple[float, float]] = {}   # level -> (ratio, when)
        self.now = 0.0   # the latest start_frame's time
        self.costed: tuple[int, FogParams | None] = (-1, None)   # the look last costed, and its version
        # the scene pass this session's worker holds at each frame size: (scene, camera, sun,
        # sunlight target), whether with MSAA and whether a preview drew it (render/targets.py
        # keeps one per slot and size; a preview's may be lit by the preview shadow map,
        # render/passes/shadow.py, which only previews reuse)
        self.scenes: dict[tuple[int, int], tuple[tuple, bool, bool]] = {}
        # the sizes whose scene pass the worker let go although this session drew it last
        # (its cache outgrew its budget, render/targets.py): until a frame finds it held
        # again, frames are estimated with their scene pass drawn (measured)
        self.scenes_lost: dict[tuple[int, int], float] = {}   # size -> when
        # at each size, the held-fog key of the last frame (_held_fog_of; render/passes/fog.py)
        # and how many frames in a row asked for it over a held scene pass
        self.fogs: dict[tuple[int, int], tuple[tuple, int]] = {}
        self._splits: list[tuple] = []   # (layers, wind, _split's answer), newest first
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

    def camera_state(self) -> dict[str, Any]:
        """The reply to a camera message: the version and the camera alone (its canonical
        form, and its keys of the canonical query, which the client splices into the query
        it holds), not the look: a look of many layers is tens of KB, its camera 100 bytes."""
        return {"type": "camera", "version": self.version, "camera": self.fog.camera.model_dump(mode="json"),
                "query": encode_field(self.fog, "camera")}

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
                self.level_ratios.clear()   # another look: its costs are its own
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
                # a camera patch changes the camera alone: its reply is the camera's
                return [self.camera_state() if isinstance(msg, CameraMsg) else self.state(now)]
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
            if (msg.width, msg.height) != (self.view.width, self.view.height):
                self.level_ratios.clear()   # the levels are other sizes now
                self.scenes_lost.clear()
            if _shown(msg.show, msg.layer) != _shown(self.view.show, self.view.layer):
                # a view that teaches costs otherwise than the shaded frame: its levels
                # are measured anew, and its first frame's ratio replaces the session's
                self.level_ratios.clear()
                self.calibrated = False
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
                self.link.acked(msg.frame, now)
            return []
        if isinstance(msg, PongMsg):
            self.link.pong(msg.ping, now)
            return []
        return [{"type": "error", "msg": f"unhandled message {type(msg).__name__}"}]

    # ------------------------------------------------------------ scheduling

    def in_flight(self) -> int:
        return (self.sent - self.acked) + self.making

    def window(self) -> int:
        """Frames that may be unacknowledged or being made: two, and those its link's round
        trip holds (stream/link.py pipe_frames)."""
        return MAX_IN_FLIGHT + self.link.pipe_frames()

    def previewing(self, now: float) -> bool:
        return self.interacting or now - self.last_input < INPUT_SETTLE_S

    def wants_frame(self, now: float) -> bool:
        """Something new to show: time runs, the look changed, or a refinement is owed
        (never while the look whose frame was stopped at its deadline is unchanged)."""
        if self.stalled == self.version:
            return False
        return (self.playing or self.dirty
                or ((not self.last_full or self.refine_owed) and not self.previewing(now)))

    def next_due(self, now: float) -> float | None:
        """When the next frame may start (None: nothing to send until something changes)."""
        if self.in_flight() >= self.window():
            return None   # an ack or a finished frame wakes the scheduler
        if not self.view_known and now < self.created + VIEW_WAIT_S:
            return self.created + VIEW_WAIT_S   # no frame at a size the client did not ask for
        if not self.wants_frame(now):
            if not self.last_full and self.previewing(now):
                return self.last_input + INPUT_SETTLE_S   # the refinement, once input settles
            return None
        return max(now, self.last_start + 1.0 / self.view.fps, self.not_before)

    def preview_budget(self) -> float:
        """The render budget of this session's previews, by its view's size (preview_budget_ms)."""
        return preview_budget_ms(self.view.width, self.view.height)

    @property
    def preview_scale(self) -> float:
        return PREVIEW_RUNGS[self.preview_rung][0]

    def _preview_still(self, fog: FogParams, rung: int, now: float) -> StillParams:
        """The look as previewed on a rung: coarser fog (no finer than 1/2, 1/4 past 640x360),
        its share of the view's side (the view's shape kept, the short side at least
        PREVIEW_MIN_SIDE or the view's own) and its detail."""
        v = self.view
        k, detail = PREVIEW_RUNGS[rung]
        eff = fog.effects.model_copy(update={"fog_scale": max(fog.effects.fog_scale,
                                                              2 if v.width * v.height <= 640 * 360 else 4)})
        width, height = v.width, v.height
        if k < 1.0:
            k = min(1.0, max(k, PREVIEW_MIN_SIDE / min(v.width, v.height)))
            width, height = (max(2, 2 * round(side * k / 2)) for side in (v.width, v.height))
        layers = fog.layers
        if detail < 1.0:
            layers = [_detailed(l, detail) for l in layers]
        return StillParams.model_construct(**{**dict(fog), "layers": layers, "effects": eff,
                                              "time": self.sim_time(now), "width": width, "height": height})

    @staticmethod
    def _scene_of(still: StillParams) -> tuple:
        return (still.scene, still.camera, still.sun, still.effects.sun_through_fog)

    def _split(self, still: StillParams) -> tuple[tuple, bool]:
        """The look's layers split by time (kinds/packing.py split_by_time): the held layers
        and whether any moves, and whether the two programs it is then drawn with compile
        fast enough (HOLD_COMPILE_S; a look where nothing moves compiles nothing). Kept
        for the last few layer lists: the estimates ask several times a frame."""
        from fogbank.workers.cost import jit_seconds
        for layers, wind, out in self._splits:
            if layers is still.layers and wind == still.wind:
                return out
        held, moving = split_by_time(still)
        parts = [variant(held), variant(moving)]
        out = ((held.layers, bool(moving.layers)),
               not parts[1] or sum(jit_seconds(v) for v in parts) <= HOLD_COMPILE_S)
        self._splits = [(still.layers, still.wind, out)] + self._splits[:3]
        return out

    def _held_fog_of(self, still: StillParams) -> tuple:
        """What the fog a worker holds over a still scene pass depends on (render/passes/fog.py
        held_key): the layers that do not change with time, the look's fog effects, and
        whether any layer moves (the worker then holds sums, else the fog target itself)."""
        return (*self._split(still)[0], still.effects, still.density, still.noise)

    def _holds_fog(self, still: StillParams) -> bool:
        """Whether a full frame of `still` asks its worker to hold the fog's time-invariant
        part: time runs, the frame shows the look, and the two programs it is drawn with
        compile fast enough (HOLD_COMPILE_S)."""
        return self.playing and self.showing() == "shaded" and self._split(still)[1]

    def _fog_held(self, still: StillParams, msaa: bool) -> bool:
        """Whether the worker draws this full frame over a held fog it drew before: the frame
        asks for it, its scene pass is held, and the last two frames at this size asked for
        the same over a held scene pass (the worker's first such frame marks the held fog
        seen, its second draws it, in full and more; the third is the first that saves)."""
        size = (still.width, still.height)
        key, frames = self.fogs.get(size, (None, 0))
        return (frames >= 2 and self._scene_cached(still, msaa) and key == self._held_fog_of(still)
                and self._holds_fog(still))

    def _lost(self, size: tuple[int, int]) -> bool:
        """Whether the worker let this size's scene pass go within LOST_S of the frame
        being started (self.now)."""
        return self.now - self.scenes_lost.get(size, -math.inf) < LOST_S

    def _scene_cached(self, still: StillParams, msaa: bool, draft: bool = False) -> bool:
        """Whether the worker holds this frame's scene pass: the last frame at its size drew
        the same scene, camera and sun (a frame without MSAA reuses one with it, a preview
        (`draft`) a full frame's, a full frame no preview's)."""
        size = (still.width, still.height)
        drawn = self.scenes.get(size)
        return (not self._lost(size) and drawn is not None and drawn[0] == self._scene_of(still)
                and (drawn[1] or not msaa) and (draft or not drawn[2]))

    def _drew(self, still: StillParams, msaa: bool, hold_fog: bool = False, draft: bool = False) -> None:
        size, key = (still.width, still.height), self._scene_of(still)
        last, frames = self.fogs.pop(size, (None, 0))
        if hold_fog and self._scene_cached(still, msaa):   # fog is held only over a held scene pass
            fog = self._held_fog_of(still)
            self.fogs[size] = (fog, frames + 1 if fog == last else 1)
            while len(self.fogs) > 2 * len(PREVIEW_RUNGS):
                self.fogs.pop(next(iter(self.fogs)))
        if not self._scene_cached(still, msaa, draft) or msaa:
            self.scenes.pop(size, None)
            self.scenes[size] = (key, msaa, draft)
            while len(self.scenes) > 2 * len(PREVIEW_RUNGS):
                self.scenes.pop(next(iter(self.scenes)))

    def _estimate_ms(self, still: StillParams, msaa: bool = False, held: bool = True, full: bool = False,
                     steady: bool = False) -> float:
        """The cost model's render time of a frame (workers/cost.py), uncalibrated, without
        what a worker does once (compiling a fog program, baking a noise tile): those are
        not this look's cost per frame; nor the scene pass while the worker holds it (a
        slider dragged, or time running, with the camera still: a playing look's full frame
        at 720p is a third of one with its scene drawn), nor, while time runs over a still
        camera, the fog the worker holds for a `full` frame (_fog_held); `held` False: the
        look's own cost, the scene and the whole fog drawn (two looks compared are compared
        alike). `steady`: a full frame once the worker holds what it would (the camera
        still): the scene pass, unless the worker let it go at this size, and the fog the
        frame asks it to hold."""
        from fogbank.workers.cost import estimate
        if steady:
            scene = not self._lost((still.width, still.height))
            fog = scene and self._holds_fog(still)
        else:
            scene = held and self._scene_cached(still, msaa, draft=not full)
            fog = held and full and self._fog_held(still, msaa)
        return estimate(still, msaa=msaa, compiled=True, baked=True, scene_cached=scene,
                        fog_held=fog).seconds * 1000.0

    def _recost(self, fog: FogParams, now: float) -> None:
        """On a new look whose estimate at the current rung differs from the last costed
        look's (at that rung) by PREVIEW_RECOST, or on a session's first preview estimated
        PREVIEW_FIRST_OVER times over the budget, start from the sharpest rung whose
        estimate, calibrated by this session's measurements, is within the budget (else the
        last rung), and forget the old look's measurements."""
        _, old = self.costed
        est = self._estimate_ms(self._preview_still(fog, self.preview_rung, now), held=False)
        last = (self._estimate_ms(self._preview_still(old, self.preview_rung, now), held=False)
                if old is not None else None)
        if (max(est / last, last / est) > PREVIEW_RECOST if last is not None
                else max(self.cost_ratio, 1.0) * est > PREVIEW_FIRST_OVER * self.preview_budget()):
            self.preview_costs.clear()
            self.level_ratios.clear()
            self.preview_rung = next(
                (i for i in range(len(PREVIEW_RUNGS))
                 if self.cost_ratio * self._estimate_ms(self._preview_still(fog, i, now)) <= self.preview_budget()),
                len(PREVIEW_RUNGS) - 1)
        self.costed = (self.version, fog)

    def _refinement(self, fog: FogParams, now: float, share: int = 1) -> tuple[StillParams, bool]:
        """The frame after input stops, and whether with MSAA: the full look, unless its
        calibrated estimate is over REFINE_BUDGET_MS (PLAY_BUDGET_MS while time runs; see
        there); then the first of (no MSAA, the preview rungs) that fits. With hysteresis: a
        quality is left for a lower one only past 1.25 times the budget, for a higher one
        only under 0.8 times it, so that a look near the budget does not flicker between;
        and to a level not measured only next to one that was (a preview measures its
        rung's level). Each level's estimate is calibrated by what its own frames (and
        previews) measured against theirs, else by the nearest cheaper level's that were
        measured, else by the session's: 16 layers of every kind were estimated (before the
        scene pass's refit, workers/cost.py) at 497 ms 240 px wide and at 865 ms 960 px wide,
        measured at 7-20 and 230-250; calibrated by one ratio
        (0.06 after 240 px previews), a new session's first refinements were 960 px wide
        with MSAA, 700-930 ms each, and then went back and forth between 336 and 960 px; a
        slider's change waited for such a frame (p95 580-650 ms)."""
        v = self.view
        still = StillParams.model_construct(**{**dict(fog), "time": self.sim_time(now),
                                               "width": v.width, "height": v.height})
        whole = PLAY_BUDGET_MS if self.playing else REFINE_BUDGET_MS
        budget = whole / max(1, share) if self.playing else whole
        n = 2 + len(PREVIEW_RUNGS)

        def level(i: int) -> tuple[StillParams, bool]:   # built only when asked (every full frame)
            return (still, i == 0) if i < 2 else (self._preview_still(fog, i - 2, now), False)

        lr = {k: r for k, (r, t) in self.level_ratios.items() if now - t <= RATIO_TTL_S}

        costs: dict[tuple[int, bool], float] = {}   # each level's estimate once per frame

        def cost(i: int, steady: bool) -> float:
            if (i, steady) not in costs:
                ratio = next((lr[j] for j in range(i, n) if j in lr), self.cost_ratio)
                costs[i, steady] = ratio * self._estimate_ms(*level(i), full=True, steady=steady)
            return costs[i, steady]

        def known(i: int) -> bool:   # measured, next to a level that was, or cheaper than all
            return not lr or i in lr or i + 1 in lr or i > min(lr)

        # Once calibrated, a level is held to the budget by the cost of its frames once the
        # worker holds what it would (steady): the first frames at a new size draw its scene
        # pass and the whole fog, paid once (8 streams of 640x360 on a worker, each held to
        # an eighth of the budget, never went back above 160 px: a size's first frame looked
        # too costly). That first frame is held to the whole budget: the first frames of 16
        # layers of volume noise at 960x540 with MSAA take 8 s, its steady ones 13 ms; and a
        # level is kept only while its next frame is too (a held fog's first two frames
        # draw the whole fog: 16 layers of volume noise 240 px wide, 3 ms a frame once held,
        # took 420 ms for each of those, and a slider's change waited for the second). After
        # QUIET_S without input, the first frames may take longer: 1920x1080 streams were
        # never drawn with MSAA (its first frame takes 500 ms, the next 65).
        steady = self.calibrated and bool(lr)
        quiet = now - self.last_input >= QUIET_S

        first = max(whole, QUIET_FIRST_MS) if quiet else whole   # what a level's first frames may take
        if share > 1:
            first = min(first, SHARED_FIRST_MS)

        def fits(i: int, share_of_budget: float) -> bool:
            return (cost(i, steady) <= share_of_budget * budget
                    and (not steady or cost(i, False) <= first))
        keep = min(self.refine_level, n - 1)
        # from a measured level, a cheaper one is taken at once; any other only next to a
        # measured one (a new session's level 0 is not measured)
        at = keep if keep in lr else n
        want = next((i for i in range(n) if (i > at or known(i)) and fits(i, 1.0)), n - 1)
        if (want > keep and known(keep) and fits(keep, 1.25)) or (want < keep and not fits(want, 0.8)):
            want = keep
        self.refine_level = want
        # a level that fits but was passed over for not being known yet is climbed to, a
        # level a frame, also while paused: a drag's first preview may start on the last
        # rung and forget what was measured (_recost), and a paused look then stayed on its
        # next level, a quarter of the view's side, until the next input
        self._climb = want > next((i for i in range(n) if fits(i, 1.0)), n - 1)
        return level(want)

    def start_frame(self, now: float, share: int = 1) -> FrameJob:
        """The next frame; `share`: how many sessions play or preview on this session's
        worker, this one included (their frames are drawn in turn: PLAY_BUDGET_MS)."""
        self.now = now
        preview = self.previewing(now)
        v = self.view
        fog = self.fog
        msaa, reduced = True, False
        if preview:   # cheaper while dragging: coarser fog, no MSAA, lower JPEG quality, the ladder
            if self.costed[0] != self.version:
                self._recost(fog, now)
            still = self._preview_still(fog, self.preview_rung, now)
            estimate_ms = self._estimate_ms(still)
        else:
            still, msaa = self._refinement(fog, now, share)
            reduced = self.refine_level > 0
            estimate_ms = self._estimate_ms(still, msaa=msaa, full=True)
        # the frame that fits the viewer's link (stream/link.py): quality first, then, while
        # time runs, size; a paused look's final frame is always the look's own
        quality = min(v.quality, PREVIEW_QUALITY) if preview else v.quality
        # video for the frames drawn while time runs (the view's own size: a new size is a
        # keyframe), JPEG for previews, a paused look's final frame and views that teach
        codec = next((c for c in v.codecs if c != "jpeg" and (self.decoders is None or c in self.decoders)), "jpeg")
        video = codec != "jpeg" and not preview and self.playing and self.showing() == "shaded"
        bitrate = 0
        if video:
            bitrate = video_bitrate(still.width * still.height,
                                    self.link.rate_bps() if self.link.limiting else None)
        elif preview or self.playing:
            if not preview:
                k = self.fit.scale(self.link, quality, still.width * still.height, now)
                if k < 1.0:
                    still = still.model_copy(update={"width": max(16, 2 * round(still.width * k / 2)),
                                                     "height": max(16, 2 * round(still.height * k / 2))})
            quality = self.fit.quality(self.link, quality, still.width * still.height)
        hold = not preview and self._holds_fog(still)
        cached = self._scene_cached(still, not preview and msaa, preview)
        self._drew(still, not preview and msaa, hold, preview)
        self.frame += 1
        self.making += 1
        self.last_start = now
        self.dirty = False
        self.last_full = not preview
        self.refine_owed = False
        if preview:
            self._climb = False
        need_key, self.need_key = self.need_key, self.need_key and not video
        return FrameJob(self.frame, self.version, still, msaa=not preview and msaa,
                        quality=quality, codec=codec if video else "jpeg", bitrate=bitrate,
                        keyframe=video and need_key,
                        full=not preview, playing=self.playing, show=self.showing(), layer=v.layer,
                        scale=self.preview_scale if preview else 1.0,
                        rung=self.preview_rung if preview else 0,
                        estimate_ms=estimate_ms, reduced=reduced, hold_fog=hold, scene_cached=cached,
                        level=2 + self.preview_rung if preview else self.refine_level)

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

    def measured(self, job: FrameJob, render_ms: float, now: float, once: bool = False,
                 scene_reused: bool | None = None, scene_warped: bool = False) -> None:
        """A frame's render time. Previews climb PREVIEW_RUNGS by what they cost: a
        preview over its budget (preview_budget) makes the next one a rung lower; one well
        under it (a fifth to spare) a rung higher, unless that rung was measured over the
        budget within PREVIEW_COST_TTL_S. Costs are measured, not modelled: a frame's
        fixed costs (shadow map, sky, particles) do not shrink with its pixels, so a step
        down that did not pay (the rung above cost at most a quarter more) is taken back,
        and one known not to pay is not taken. What frames measure against their estimates
        calibrates the estimates of the next new look (_recost) and of the refinement.
        A frame that did work once (`once`: compiled a program, baked a noise tile) is
        neither a rung's cost nor a calibration. `scene_reused`: whether the worker drew
        over the scene pass it held (None: not known); one it let go (its cache held other
        sessions' scene passes, render/targets.py) makes this session's frames at that size
        estimated with their scene pass drawn until one finds it held again, and a frame
        whose estimate took the other case calibrates nothing: several 1280x720 streams on
        one worker, two of whose scene passes fit, had the others' full frames estimated at
        25 ms, measured at 230 (the scene pass with MSAA), calibrated 9x over and kept with
        MSAA; estimated with their scene pass they are drawn without MSAA (80 ms). A preview
        whose scene pass the worker warped from an earlier one (`scene_warped`,
        render/reproject.py) is its rung's cost, but calibrates nothing: the model prices a
        scene pass drawn whole, and a ratio taken from the cheaper warp would price the
        refinement, whose scene pass is drawn whole, too low."""
        surprised = False
        if scene_reused is not None:
            size = (job.still.width, job.still.height)
            if scene_reused:
                self.scenes_lost.pop(size, None)
            elif job.scene_cached:
                self.scenes_lost[size] = now
            surprised = scene_reused != job.scene_cached
        if job.full and job.version == self.version and job.level == self.refine_level:
            self.refine_owed = self._climb   # measured (or, once, to be measured again)
        if once:   # it compiled a program or baked a noise tile: not what this look costs
            return
        self.last_ms = render_ms
        self.last_level = job.level if job.full else None
        # a frame of the view shown before a switch calibrates nothing of the view now shown
        same_view = _shown(job.show, job.layer) == _shown(self.showing(), self.view.layer)
        if job.estimate_ms > 0 and not surprised and not scene_warped and same_view:   # raw estimate: measured / estimated, smoothed
            r = min(max(render_ms / job.estimate_ms, 0.05), 20.0)
            # the first measurement replaces the prior: smoothed with 1.0, a look the model
            # underestimates twice over was still underestimated by 1.4 on the next frame
            # (16 layers of volume noise: its first playing frame took 409 ms of 300)
            self.cost_ratio = (math.exp(0.5 * math.log(self.cost_ratio) + 0.5 * math.log(r))
                               if self.calibrated else r)
            self.calibrated = True
            # each view's levels are its own (a view that teaches costs otherwise: the
            # difference view climbed by the shaded frame's ratios to 200 ms frames beside a
            # stream; issue 33)
            old = self.level_ratios.get(job.level)
            fresh = old is not None and now - old[1] <= RATIO_TTL_S
            self.level_ratios[job.level] = (math.sqrt(old[0] * r) if fresh else r, now)
        if job.full:
            return
        # a rung's cost: its frames' running mean (a quarter each), so that a drag whose
        # previews warp (render/reproject.py: cheap frames, and every few a frame drawn
        # whole) is held to their mean, not to the last one (with half each, one whole
        # frame took a 640 px drag back up to 960)
        prev = self.preview_costs.get(job.rung)
        ms = render_ms if prev is None or now - prev[1] > PREVIEW_COST_TTL_S else 0.75 * prev[0] + 0.25 * render_ms
        self.preview_costs[job.rung] = (ms, now)
        if job.rung != self.preview_rung:
            return   # a frame of an earlier rung: recorded, no step taken
        i = self.preview_rung
        budget = self.preview_budget()
        fresh = lambda k: (c := self.preview_costs.get(k)) is not None and now - c[1] <= PREVIEW_COST_TTL_S  # noqa: E731
        if not scene_warped and i > 0 and fresh(i - 1) and self.preview_costs[i - 1][0] <= 1.25 * ms:
            # the step down did not pay (the cost is fixed, not in the pixels): back up. A
            # warped preview says nothing of that: its cost is what its base saw
            self.preview_rung = i - 1
        elif ms > budget and i + 1 < len(PREVIEW_RUNGS):
            # no step down that did not pay: a look whose cost is fixed (not in its
            # pixels) keeps its sharper preview
            if not (fresh(i + 1) and self.preview_costs[i + 1][0] > 0.8 * ms):
                self.preview_rung = i + 1
        elif ms < 0.8 * budget and i > 0:
            if not fresh(i - 1) or self.preview_costs[i - 1][0] <= budget:
                self.preview_rung = i - 1

    def redo(self, after: float | None = None) -> None:
        """A frame was lost to the server, not to the look (its worker stalled or died), or
        its worker was not ready for it (a noise tile baking): draw the look again, whether
        or not its time runs; not before `after` (monotonic s) when given."""
        self.dirty = True
        if after is not None:
            self.not_before = after

    def frame_done(self, job: FrameJob, sent: bool) -> None:
        """A frame was sent (or dropped: failed, stale, or the client left)."""
        self.making -= 1
        if sent:
            self.sent = max(self.sent, job.frame)
