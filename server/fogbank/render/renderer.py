"""The GL renderer of one worker process: a frame is a list of passes (render/passes),
drawn on the thread that created the context, with the fog's CPU work (particle
simulation, packing) prepared on a thread of its own meanwhile (render/frame.py).

Programs, meshes, the noise tiles and the render targets are built once and reused; the
scene pass (G-buffer) is cached per slot while scene, camera, sun and size do not
change. The transmittance API (render/rays.py) shares the programs and the fog plan.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import moderngl
import numpy as np

from fogbank.render.frame import Frame, Simulations, plan_fog
from fogbank.render.gl import create_context  # noqa: F401  (the worker's entry point)
from fogbank.render.passes import FRAME_PASSES
from fogbank.render import reproject
from fogbank.render.programs import Programs
from fogbank.render.rays import RayCaster
from fogbank.render.passes.shadow import sun_key
from fogbank.render.resources import Meshes, NoiseTiles, ShadowMaps, particle_texture
from fogbank.render.targets import TargetCache
from fogbank.scene import camera as cam

CACHE_BYTES = 256 << 20   # default byte budget of the GL caches (targets and scene passes)


class Renderer:
    def __init__(self, ctx: moderngl.Context, cache_bytes: int = CACHE_BYTES, clock=time.monotonic):
        self.ctx = ctx
        self.programs = Programs(ctx)
        self.sky_prog = self.programs.get("passes/sky.vert", "passes/sky.frag")
        self.scene_prog = self.programs.get("passes/scene.vert", "passes/scene.frag", TERRAIN=0)
        self.terrain_prog = self.programs.get("passes/scene.vert", "passes/scene.frag", TERRAIN=1)
        self.shadow_prog = self.programs.get("passes/shadow.vert", "passes/shadow.frag")
        self.lightmap_prog = self.programs.get("passes/lightmap.vert", "passes/lightmap.frag")
        self.meshes = Meshes(ctx, self.terrain_prog, self.scene_prog, self.shadow_prog, self.lightmap_prog)
        self.shadows = ShadowMaps(ctx)
        self.noise = NoiseTiles(ctx)
        self.particles = particle_texture(ctx)
        self.caches = TargetCache(ctx, cache_bytes, clock)
        # whether the latest frame's scene pass was the cached one (begin): a stream's
        # session learns from it that the cache let its scene pass go (stream/session.py)
        self.scene_reused = False
        # what the latest frame warped from an earlier preview (render/reproject.py): None,
        # "scene" (its scene pass) or "frame" (its finished frame); a warped frame's cost
        # says little of what the look costs (stream/session.py does not calibrate by it)
        self.warped: str | None = None
        self.sims = Simulations()
        self.rays = RayCaster(self)
        self._prep = ThreadPoolExecutor(1, thread_name_prefix="fog-plan")

    # ------------------------------------------------------------ frames

    def begin(self, still, slot: str = "still", msaa: bool = True, hold_fog: bool = False,
              draft: bool = False) -> Frame:
        """A frame's inputs: its targets and view, and its fog plan set going on the
        preparation thread. `hold_fog`: with the scene pass held (the camera still), the
        fog's time-invariant part is kept with it for the next frames (passes/fog.py).
        `draft`: a preview, lit by the preview shadow map unless a full one of this sun
        is kept (passes/shadow.py)."""
        w, h = still.width, still.height
        view = cam.view(still.camera, w, h)
        g = self.caches.gbuffer(slot, w, h, still.effects.sun_through_fog)
        coarse = draft and self.shadows.get(sun_key(still)) is None
        key = (still.scene, still.camera, still.sun, msaa, draft)
        # a preview happily reuses a full-quality scene pass, and another preview's (which
        # may be lit by the preview shadow map); a frame without MSAA, one with it; never
        # the other way round (stream/session.py _scene_cached takes it the same way)
        old = g.scene_key
        cached = (old is not None and old[:3] == key[:3] and (old[3] or not msaa) and (draft or not old[4]))
        g.last_frame = "reused" if cached else ("new" if g.scene_key is None else "redrawn")
        self.scene_reused = cached
        # a preview that only turned the camera since an earlier one warps: its finished
        # frame, from the slot's last preview of the same look drawn whole, at its size or
        # larger (the part it did not see drawn and composited anew), else its scene pass,
        # from the slot's latest preview scene pass (render/reproject.py); a full frame
        # lets the bases go (the drag is over)
        warp = out_warp = None
        look = reproject.look_key(still, coarse) if draft and not msaa else None
        if not draft and (g.warp_base is not None or g.out_base is not None):
            self.caches.park()   # never release the bound framebuffer
            g.drop_warp_base()
        out_src = None
        if not cached and look is not None:
            if still.effects.blur == "off":
                out_src = self.caches.out_source(slot, (w, h), still.effects.sun_through_fog, look, still.time,
                                                 reproject.OUT_MAX_AGE_S)
            # a frame that turned (held still, it would show the base's moment again)
            if out_src is not None and out_src.out_view.view_proj.tobytes() != view.view_proj.tobytes():
                out_warp = reproject.plan(out_src.out_view, view, w, h, out_src.out_base)
            if out_warp is None:
                src = self.caches.warp_source(slot, (w, h), still.effects.sun_through_fog,
                                              reproject.warp_key(still, coarse))
                if src is not None:
                    warp = reproject.plan(src.warp_view, view, w, h, src.warp_base)
        self.warped = "frame" if out_warp is not None else ("scene" if warp is not None else None)
        plan = None
        if look is not None:
            # a warped frame shows the look at its base's time, the part drawn anew too (no
            # seam between what moved and what did not), and takes the plan of the frames
            # before it at that time: the same look, eye and time make the same plan (the
            # particles simulated and lit, the layers packed: CPU work that competed with
            # the GL for the two cores)
            if out_warp is not None:
                still = still.model_copy(update={"time": out_src.out_time})
            plan_key = (look, still.time, tuple(view.eye), hold_fog and cached)
            for kept in (g.last_plan, out_src.last_plan if out_warp is not None else None):
                if kept is not None and kept[0] == plan_key:
                    plan = kept[1]
        if plan is None:
            # the plan's split (FogPlan.split) is what asks the fog pass to hold
            plan = self._prep.submit(plan_fog, still, still.time, view.eye, self.sims, hold_fog and cached, True)
            if look is not None:
                g.last_plan = (plan_key, plan)
        return Frame(still=still, slot=slot, msaa=msaa, view=view,
                     targets=self.caches.targets(w, h), gbuffer=g, plan=plan,
                     scene_key=key, scene_cached=cached, draft=draft, coarse_shadow=coarse, warp=warp, out_warp=out_warp,
                     look_key=look)

    @property
    def scene_warped(self) -> bool:
        return self.warped is not None

    def render(self, still, slot: str = "still", msaa: bool = True, hold_fog: bool = False,
               draft: bool = False, lend: bool = False, channels: int = 3) -> np.ndarray:
        """The frame as (height, width, 3) uint8 sRGB, top row first. `slot` names whose
        scene pass is cached (a session id; stills share one); `msaa` off is the cheap
        preview used while a user drags, and `draft` lets it take the preview shadow map;
        `hold_fog` keeps the fog's time-invariant part while the camera stays (a stream's
        frames: time runs, the camera is still). `lend`: the frame size's readback buffer
        itself (passes/output.py), overwritten by the next frame of that size, for a caller
        that encodes it at once (workers/worker.py); else a copy the caller owns.
        `channels` 4: RGBX (alpha 255), which reads back faster, for a JPEG."""
        frame = self.begin(still, slot, msaa, hold_fog, draft)
        frame.channels = channels
        for p in FRAME_PASSES:
            p.run(self, frame)
        self.keep_only(frame)
        return frame.image if lend else frame.image.copy()

    def transmittance(self, fog, origins, directions, lengths, times) -> np.ndarray:
        return self.rays.transmittance(fog, origins, directions, lengths, times)

    def light(self, fog, origins, directions, lengths, times) -> dict[str, np.ndarray]:
        return self.rays.light(fog, origins, directions, lengths, times)

    # ------------------------------------------------------------ info and caches

    def info(self) -> dict[str, str]:
        i = self.ctx.info
        return {"renderer": i["GL_RENDERER"], "version": i["GL_VERSION"], "vendor": i["GL_VENDOR"]}

    def probe(self) -> bool:
        """Clear a 1x1 target to a known colour and read it back (a liveness probe that
        goes through the GL pipeline, not just the Python side)."""
        fbo = self.caches.park_fbo   # never released: safe to use as the probe's target
        fbo.use()
        fbo.clear(0.2, 0.4, 0.6, 1.0)
        return fbo.read(components=4, alignment=1)[:4] == bytes((51, 102, 153, 255))

    def keep_only(self, frame: Frame) -> None:
        """Hold the caches to budget, keeping the frame just drawn: its size's targets and
        its slot's scene pass."""
        self.caches.trim(keep_targets=[frame.targets.size],
                         keep_gbuffers=[(frame.slot, *frame.targets.size, frame.gbuffer.sunlight is not None)])

    def trim(self, keep_targets=(), keep_gbuffers=()) -> None:
        """Hold both GL caches to their byte budgets."""
        self.caches.trim(keep_targets, keep_gbuffers)

    def cache_bytes(self) -> int:
        return self.caches.nbytes()

    def release_caches(self) -> None:
        """Free every cached target, scene pass, noise tile and full shadow map (a worker
        over its memory budget)."""
        self.caches.clear()
        self.noise.clear()
        self.shadows.clear()

    def drop_slot(self, slot: str) -> None:
        """Free a slot's cached scene passes (a session ended)."""
        self.caches.drop_slot(slot)

