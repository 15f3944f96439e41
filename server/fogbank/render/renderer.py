"""The GL renderer: scene pass, fog pass, composite, blur, readback.

Owned by one render worker process (worker.py): every method here makes GL calls and
must run on the thread that created the context. Programs, meshes, the noise texture and the
render targets are built once and reused; the scene pass (G-buffer) is cached while
scene, camera, sun and size do not change.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np

from fogbank.scene import camera as cam
from fogbank.scene import meshes as scenes
from fogbank.scene import terrain
import time
from collections import OrderedDict

from fogbank.kinds.kind import LAYER_VEC4
from fogbank.kinds.packing import DEFINES, direct_density, enabled, generated, pack, uses_noise, variant
from fogbank.kinds.noise_bake import bake
from fogbank.model.params import MAX_PARTICLES, FogParams, StillParams, srgb_to_linear
from fogbank.kinds.particle_motion import simulate
from fogbank.render.glsl import program
from fogbank.render.cache import ByteLRU

MSAA_SAMPLES = 4
SHADOW_SIZE = 2048
RAYS_PER_ROW = 1024
SIM_CACHE = 64            # particle states kept (at most 16 layers x 1024 particles each)
CACHE_BYTES = 256 << 20   # default byte budget of the GL caches (targets and scene passes)
TEX = {"uColor": 0, "uInvDist": 1, "uFog": 2, "uParticles": 3, "uNoise": 4, "uShadow": 5,
       "uRays": 6, "uImage": 0}


def create_context(backend: str = "auto", device: int | None = None) -> moderngl.Context:
    """A standalone context on EGL (GPU if the EGL device is one, else Mesa llvmpipe)."""
    if backend == "default":
        return moderngl.create_context(standalone=True, require=330)
    kwargs = {"device_index": device} if device is not None else {}
    return moderngl.create_context(standalone=True, backend="egl", require=330, **kwargs)


def _set(prog, name: str, value) -> None:
    """Set a uniform if the program uses it (unused uniforms are optimised away)."""
    if name not in prog:
        return
    u = prog[name]
    if isinstance(value, np.ndarray) and value.ndim == 2 and value.shape == (4, 4):
        u.write(value.T.astype("f4").tobytes())  # GL matrices are column-major
    elif isinstance(value, np.ndarray):
        u.value = tuple(float(v) for v in value)
    else:
        u.value = value


def release_fbo(fbo: moderngl.Framebuffer | None) -> None:
    """Release a framebuffer and everything attached to it (renderbuffers and textures):
    releasing the framebuffer alone leaves its attachments allocated."""
    if fbo is None:
        return
    attachments = list(fbo.color_attachments) + [fbo.depth_attachment]
    fbo.release()
    for a in attachments:
        if a is not None:
            a.release()


# bytes per pixel of each GPU allocation (for the caches' byte budgets)
OUT_BPP = 4                                   # RGBA8 output renderbuffer
MSAA_BPP = MSAA_SAMPLES * (8 + 4 + 4)         # RGBA16F + R32F + depth24/stencil8, per sample
LINEAR_BPP = 2 * 8                            # two RGBA16F blur targets
GBUFFER_BPP = 8 + 4 + 4                       # RGBA16F colour, R32F inverse distance, depth


@dataclass
class Targets:
    """Scratch render targets for one frame size, shared by every caller (one frame is
    drawn at a time by a worker)."""
    size: tuple[int, int]
    out: moderngl.Framebuffer
    msaa: moderngl.Framebuffer | None = None
    fog: dict[int, tuple[moderngl.Framebuffer, moderngl.Texture]] = field(default_factory=dict)
    linear: list[tuple[moderngl.Framebuffer, moderngl.Texture]] = field(default_factory=list)

    def nbytes(self) -> int:
        w, h = self.size
        n = w * h * OUT_BPP
        if self.msaa is not None:
            n += w * h * MSAA_BPP
        for scale in self.fog:
            n += -(-w // scale) * -(-h // scale) * 8
        n += len(self.linear) * w * h * 8
        return n

    def release(self) -> None:
        for fbo in [self.out, self.msaa] + [f for f, _ in self.fog.values()] + [f for f, _ in self.linear]:
            release_fbo(fbo)
        self.fog.clear()
        self.linear.clear()
        self.msaa = None


@dataclass
class GBuffer:
    """A cached scene pass (colour and inverse distance) for one slot (a streaming session,
    or stills) and size; redrawn only when scene, camera, sun or MSAA change."""
    fbo: moderngl.Framebuffer      # colour + inverse distance + single-sample depth
    color: moderngl.Texture
    invdist: moderngl.Texture
    scene_key: object = None

    def nbytes(self) -> int:
        return self.color.width * self.color.height * GBUFFER_BPP

    def release(self) -> None:
        release_fbo(self.fbo)   # colour, inverse distance and the depth renderbuffer


class Renderer:
    def __init__(self, ctx: moderngl.Context, cache_bytes: int = CACHE_BYTES):
        self.ctx = ctx
        self.empty_vao: dict = {}
        self._programs: OrderedDict = OrderedDict()
        self.sky_prog = self._program("passes/fullscreen.vert", "passes/sky.frag")
        self.scene_prog = self._program("passes/scene.vert", "passes/scene.frag")
        self.shadow_prog = self._program("passes/shadow.vert", "passes/shadow.frag")
        self.blur_prog = self._program("passes/fullscreen.vert", "passes/blur.frag")
        self.particles = ctx.texture((MAX_PARTICLES, 1), 4, dtype="f4")
        self.particles.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.shadow_tex = ctx.depth_texture((SHADOW_SIZE, SHADOW_SIZE))
        self.shadow_tex.compare_func = "<="
        self.shadow_tex.filter = (moderngl.LINEAR, moderngl.LINEAR)   # bilinear PCF per tap
        self.shadow_tex.repeat_x = self.shadow_tex.repeat_y = False
        self.shadow_fbo = ctx.framebuffer(depth_attachment=self.shadow_tex)
        self.shadow_key: object = None
        self._meshes: dict[str, tuple] = {}
        # half of the budget each: scratch targets by size, cached scene passes by slot
        self._targets = ByteLRU(cache_bytes // 2)    # (w, h) -> Targets
        self._gbuffers = ByteLRU(cache_bytes // 2)   # (slot, w, h) -> GBuffer
        self._noise: dict[tuple, moderngl.Texture] = {}
        self._no_noise: moderngl.Texture | None = None
        self._rays_fbo: tuple | None = None
        self._sim_cache: OrderedDict = OrderedDict()
        self._park_fbo: moderngl.Framebuffer | None = None

    # ------------------------------------------------------------ programs

    def _program(self, vert: str, frag: str, layers: tuple | None = None, inline_particles: bool = True,
                 **defines):
        """A compiled program, cached by its sources, defines and fog layer variant.
        Fullscreen programs get an empty VAO; texture units are set once."""
        key = (vert, frag, layers, inline_particles, tuple(sorted(defines.items())))
        if key in self._programs:
            self._programs.move_to_end(key)
            return self._programs[key]
        gen = generated(layers, inline_particles) if layers is not None else None
        prog = program(self.ctx, vert, frag, {**DEFINES, **defines}, gen)
        for name, unit in TEX.items():
            _set(prog, name, unit)
        if vert == "passes/fullscreen.vert":
            self.empty_vao[prog] = self.ctx.vertex_array(prog, [])
        self._programs[key] = prog
        # fog layer variants come and go: keep the 48 most recent (the fixed programs stay)
        variants = [k for k in self._programs if k[2] is not None]
        for k in variants[:max(0, len(variants) - 48)]:
            old = self._programs.pop(k)
            vao = self.empty_vao.pop(old, None)
            if vao is not None:
                vao.release()
            old.release()
        return prog

    def fog_program(self, fog: FogParams, scale: int, raymarch_steps: int | None = None):
        """The fog pass; particles are left to the quads pass. With raymarch_steps, the
        exponential layers are raymarched instead (the benchmark's comparison)."""
        extra = {"RAYMARCH_STEPS": raymarch_steps} if raymarch_steps else {}
        return self._program("passes/fullscreen.vert", "passes/fog.frag", variant(fog),
                             inline_particles=False, FOG_SCALE=scale, **extra)

    def particles_program(self, scale: int):
        prog = self._program("passes/particles.vert", "passes/particles.frag", FOG_SCALE=scale)
        if prog not in self.empty_vao:
            self.empty_vao[prog] = self.ctx.vertex_array(prog, [])
        return prog

    def rays_program(self, fog: FogParams):
        return self._program("passes/fullscreen.vert", "passes/rays.frag", variant(fog),
                             RAYS_PER_ROW=RAYS_PER_ROW)

    def composite_program(self, scale: int, blur_mode: int):
        return self._program("passes/fullscreen.vert", "passes/composite.frag",
                             FOG_SCALE=scale, BLUR_MODE=blur_mode)

    # ------------------------------------------------------------ info

    def info(self) -> dict[str, str]:
        i = self.ctx.info
        return {"renderer": i["GL_RENDERER"], "version": i["GL_VERSION"], "vendor": i["GL_VENDOR"]}

    def probe(self) -> bool:
        """Clear a 1x1 target to a known colour and read it back (a liveness probe that
        goes through the GL pipeline, not just the Python side)."""
        self._park()   # the never-released 1x1 framebuffer serves as the probe's target
        self._park_fbo.clear(0.2, 0.4, 0.6, 1.0)
        px = self._park_fbo.read(components=4, alignment=1)
        return px[:4] == bytes((51, 102, 153, 255))

    # ------------------------------------------------------------ resources

    def _mesh(self, name: str):
        if name not in self._meshes:
            m = scenes.build(name)
            fmt = ("3f 3f 3f 1f", "aPos", "aNormal", "aColor", "aMaterial")
            vaos = []
            if len(m.terrain_indices):
                vbo = self.ctx.buffer(m.terrain_vertices.tobytes())
                ibo = self.ctx.buffer(m.terrain_indices.tobytes())
                vaos.append((self.ctx.vertex_array(self.scene_prog, [(vbo, *fmt)], ibo, 4),
                             self.ctx.vertex_array(self.shadow_prog, [(vbo, "3f 28x", "aPos")], ibo, 4)))
            vbo = self.ctx.buffer(m.objects.tobytes())
            vaos.append((self.ctx.vertex_array(self.scene_prog, [(vbo, *fmt)]),
                         self.ctx.vertex_array(self.shadow_prog, [(vbo, "3f 28x", "aPos")])))
            self._meshes[name] = (vaos, m.bounds, m.terrain_chunks)
        return self._meshes[name]

    def _noise_tex(self, fog: FogParams) -> moderngl.Texture:
        """The baked noise tile, or a 1-texel stand-in when no enabled layer samples it
        (baking a 128^3 tile takes seconds that a look without noise should not pay)."""
        if not uses_noise(fog):
            if self._no_noise is None:
                self._no_noise = self.ctx.texture3d((1, 1, 1), 1, np.zeros(1, np.float32).tobytes(), dtype="f4")
            return self._no_noise
        key = (fog.noise.size, fog.noise.octaves, fog.noise.blur, fog.noise.seed)
        if key not in self._noise:
            data = bake(*key)
            n = key[0]
            # GL wants x fastest; the baked array is indexed [x, y, z]
            tex = self.ctx.texture3d((n, n, n), 1, np.ascontiguousarray(data.transpose(2, 1, 0)).tobytes(),
                                     dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            if len(self._noise) >= 4:
                self._noise.pop(next(iter(self._noise))).release()
            self._noise[key] = tex
        return self._noise[key]

    def _targets_for(self, w: int, h: int) -> Targets:
        return self._targets.get((w, h), lambda: Targets(
            (w, h), self.ctx.framebuffer(color_attachments=[self.ctx.renderbuffer((w, h), 4)])))

    def _park(self) -> None:
        """Bind a framebuffer that is never released: releasing the bound framebuffer
        leaves GL_INVALID_OPERATION behind (moderngl), so every release happens
        with this one bound."""
        if self._park_fbo is None:
            self._park_fbo = self.ctx.framebuffer(color_attachments=[self.ctx.renderbuffer((1, 1), 4)])
        self._park_fbo.use()

    def trim(self, keep_targets=(), keep_gbuffers=()) -> None:
        """Hold both GL caches to their byte budgets (after a frame, keeping its own)."""
        self._park()
        self._targets.trim(keep_targets)
        self._gbuffers.trim(keep_gbuffers)

    def cache_bytes(self) -> int:
        return self._targets.nbytes() + self._gbuffers.nbytes()

    def release_caches(self) -> None:
        """Free every cached target and scene pass (a worker over its memory budget)."""
        self._park()
        self._targets.clear()
        self._gbuffers.clear()
        for tex in self._noise.values():
            tex.release()
        self._noise.clear()

    def _msaa_fbo(self, t: Targets) -> moderngl.Framebuffer:
        if t.msaa is None:
            ctx, size = self.ctx, t.size
            t.msaa = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer(size, 4, samples=MSAA_SAMPLES, dtype="f2"),
                                   ctx.renderbuffer(size, 1, samples=MSAA_SAMPLES, dtype="f4")],
                depth_attachment=ctx.depth_renderbuffer(size, samples=MSAA_SAMPLES))
        return t.msaa

    def _gbuffer(self, slot: str, w: int, h: int) -> GBuffer:
        def make() -> GBuffer:
            ctx = self.ctx
            color = ctx.texture((w, h), 4, dtype="f2")
            color.repeat_x = color.repeat_y = False
            invdist = ctx.texture((w, h), 1, dtype="f4")
            invdist.filter = (moderngl.NEAREST, moderngl.NEAREST)
            fbo = ctx.framebuffer(color_attachments=[color, invdist],
                                  depth_attachment=ctx.depth_renderbuffer((w, h)))
            return GBuffer(fbo, color, invdist)
        return self._gbuffers.get((slot, w, h), make)

    def drop_slot(self, slot: str) -> None:
        """Free a slot's cached scene passes (a session ended)."""
        self._park()
        for key in [k for k in self._gbuffers.keys() if k[0] == slot]:
            self._gbuffers.pop(key)

    def _fog_target(self, t: Targets, scale: int):
        if scale not in t.fog:
            w, h = t.size
            size = (-(-w // scale), -(-h // scale))
            tex = self.ctx.texture(size, 2, dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            t.fog[scale] = (self.ctx.framebuffer(color_attachments=[tex]), tex)
        return t.fog[scale]

    def _linear_targets(self, t: Targets):
        while len(t.linear) < 2:
            tex = self.ctx.texture(t.size, 4, dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            t.linear.append((self.ctx.framebuffer(color_attachments=[tex]), tex))
        return t.linear

    # ------------------------------------------------------------ passes

    def _shadow_pass(self, fog: FogParams, vaos, bounds) -> np.ndarray:
        center, half = bounds
        sun_vp = cam.ortho_sun(fog.sun.direction(), center, half)
        key = (fog.scene, fog.sun.azimuth, fog.sun.elevation)
        if key != self.shadow_key:
            self.shadow_fbo.use()
            self.shadow_fbo.clear(depth=1.0)
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.disable(moderngl.CULL_FACE)
            _set(self.shadow_prog, "uSunViewProj", sun_vp)
            for _, shadow_vao in vaos:
                shadow_vao.render(moderngl.TRIANGLES)
            self.shadow_key = key
        return sun_vp

    def _scene_pass(self, fog: FogParams, t: Targets, g: GBuffer, view: cam.View, msaa: bool) -> None:
        key = (fog.scene, fog.camera, fog.sun, msaa)
        if g.scene_key == key or (not msaa and g.scene_key == key[:3] + (True,)):
            return   # cached; a preview happily reuses a full-quality scene pass
        ctx = self.ctx
        vaos, bounds, _ = self._mesh(fog.scene)
        sun_vp = self._shadow_pass(fog, vaos, bounds)
        sun_dir = fog.sun.direction()
        sun_col = np.array(srgb_to_linear(fog.sun.color)) * fog.sun.intensity
        target = self._msaa_fbo(t) if msaa else g.fbo
        target.use()
        target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        ctx.disable(moderngl.DEPTH_TEST)
        sp = self.sky_prog
        for name, v in (("uFwd", view.fwd), ("uRight", view.right), ("uUp", view.up),
                        ("uSunDir", sun_dir), ("uSunColor", sun_col),
                        ("uFlatSkyColor", np.array(srgb_to_linear(scenes.CALIBRATION_SKY)))):
            _set(sp, name, v)
        _set(sp, "uFlatSky", fog.scene == "calibration")
        self.empty_vao[sp].render(moderngl.TRIANGLES, vertices=3)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        pr = self.scene_prog
        _set(pr, "uViewProj", view.view_proj)
        _set(pr, "uSunViewProj", sun_vp)
        _set(pr, "uEye", view.eye)
        _set(pr, "uSunDir", sun_dir)
        _set(pr, "uSunColor", sun_col)
        _set(pr, "uShadowTexel", 1.0 / SHADOW_SIZE)
        self.shadow_tex.use(TEX["uShadow"])
        chunks = self._meshes[fog.scene][2]
        for k, (scene_vao, _) in enumerate(vaos):
            if k == 0 and len(chunks):   # terrain: nearest chunks first
                order = np.argsort(np.linalg.norm(chunks[:, 2:5] - view.eye, axis=1))
                for first, count in chunks[order, :2].astype(int):
                    scene_vao.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
            else:
                scene_vao.render(moderngl.TRIANGLES)
        ctx.disable(moderngl.DEPTH_TEST)
        if msaa:
            ctx.copy_framebuffer(g.fbo, target)  # MSAA resolve of both colour attachments
        g.scene_key = key

    def _set_fog_uniforms(self, prog, fog: FogParams, time: float, ref) -> None:
        """The fog's uniforms for one draw, its layers packed relative to the reference
        point `ref` (float64: the eye, or a group of rays' origin) at `time`."""
        states = {i: self._particle_state(l, time, fog)
                  for i, l in enabled(fog) if l.kind == "particles"}
        data, parts = pack(fog, states, ref, time)
        self._packed = (data, parts)
        if "uLayer" in prog:   # constant indexing lets the compiler trim the array
            u = prog["uLayer"]
            u.write(data[:u.array_length].tobytes())
        if states:
            self.particles.write(parts.tobytes())
        self.particles.use(TEX["uParticles"])
        self._noise_tex(fog).use(TEX["uNoise"])
        e = fog.effects
        _set(prog, "uStartDistance", e.start_distance)
        _set(prog, "uCutoffDistance", e.cutoff_distance)
        _set(prog, "uMaxOpacity", e.max_opacity)
        _set(prog, "uDensity", direct_density(fog))

    def _particle_state(self, layer, time: float, fog: FogParams):
        """A particle layer's state at `time`, simulated once per distinct (layer, time,
        wind, scene) and kept in a small LRU (rays at one time, frames of a paused look)."""
        key = (layer.model_dump_json(), float(time), tuple(fog.wind.vector()), fog.scene)
        cache = self._sim_cache
        if key in cache:
            cache.move_to_end(key)
            return cache[key]
        ground = terrain.flat if fog.scene == "calibration" else terrain.height
        cache[key] = simulate(layer, time, fog.wind.vector(), ground)
        while len(cache) > SIM_CACHE:
            cache.popitem(last=False)
        return cache[key]

    def _particle_quads(self, fog: FogParams, view: cam.View, scale: int) -> None:
        """Multiply each particle's clarity into the fog target (bound), one instanced
        quad per particle over the screen bounds of its sphere of influence. The particle
        texture was filled by _set_fog_uniforms for this frame."""
        layers = [(n, l) for n, (_, l) in enumerate(enabled(fog)) if l.kind == "particles"]
        if not layers:
            return
        data, _ = self._packed
        pp = self.particles_program(scale)
        for name, v in (("uEye", view.eye), ("uFwd", view.fwd), ("uRight", view.right),
                        ("uUp", view.up), ("uViewProj", view.view_proj)):
            _set(pp, name, v)
        _set(pp, "uDensity", direct_density(fog))
        e = fog.effects
        _set(pp, "uSkyDistance", e.sky_distance)
        _set(pp, "uStartDistance", e.start_distance)
        _set(pp, "uCutoffDistance", e.cutoff_distance)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ZERO, moderngl.SRC_COLOR   # dst *= clarity
        try:
            for slot, layer in layers:
                alpha, radius, first, count = data[slot * LAYER_VEC4]
                if count < 1:
                    continue
                _set(pp, "uFirst", int(first))
                _set(pp, "uRadius", float(radius))
                _set(pp, "uAlpha", float(alpha))
                self.empty_vao[pp].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=int(count))
        finally:
            self.ctx.disable(moderngl.BLEND)

    def _fog_pass(self, still: StillParams, view: cam.View, t: Targets, g: GBuffer,
                  raymarch_steps: int | None = None) -> moderngl.Texture:
        """Fog pass at 1/fog_scale, then the particle quads; returns the fog target."""
        e = still.effects
        fog_fbo, fog_tex = self._fog_target(t, e.fog_scale)
        fog_fbo.use()
        fp = self.fog_program(still, e.fog_scale, raymarch_steps)
        self._set_fog_uniforms(fp, still, still.time, view.eye)
        for name, v in (("uFwd", view.fwd), ("uRight", view.right), ("uUp", view.up)):
            _set(fp, name, v)
        _set(fp, "uSkyDistance", e.sky_distance)
        g.invdist.use(TEX["uInvDist"])
        self.empty_vao[fp].render(moderngl.TRIANGLES, vertices=3)
        self._particle_quads(still, view, e.fog_scale)
        return fog_tex

    def fog_only(self, still: StillParams, raymarch_steps: int | None = None, read: bool = True):
        """The scene pass (cached) and the fog pass alone; with `read`, the raw
        transmittance and inverse distance per fog texel, bottom row first (benchmarks)."""
        t = self._targets_for(still.width, still.height)
        g = self._gbuffer("bench", still.width, still.height)
        view = cam.view(still.camera, still.width, still.height)
        self._scene_pass(still, t, g, view, True)
        self.ctx.finish()
        t0 = time.perf_counter()
        tex = self._fog_pass(still, view, t, g, raymarch_steps)
        self.ctx.finish()
        ms = (time.perf_counter() - t0) * 1000.0
        if not read:
            return ms
        a = np.frombuffer(tex.read(), np.float32).reshape(tex.height, tex.width, 2)
        return ms, a[..., 0].copy(), a[..., 1].copy(), view

    def render(self, still: StillParams, slot: str = "still", msaa: bool = True) -> np.ndarray:
        """The frame as (height, width, 3) uint8 sRGB, top row first. `slot` names whose
        scene pass is cached (a session id; stills share one); `msaa` off is the cheap
        preview used while a user drags."""
        w, h = still.width, still.height
        t = self._targets_for(w, h)
        g = self._gbuffer(slot, w, h)
        view = cam.view(still.camera, w, h)
        self._scene_pass(still, t, g, view, msaa)
        e = still.effects

        fog_tex = self._fog_pass(still, view, t, g)

        # composite (with the blur fused, or followed by separate blur passes)
        blur_mode = {"off": 0, "single": 1, "separate": 2}[e.blur]
        cp = self.composite_program(e.fog_scale, blur_mode)
        sigma = e.blur_radius * h / 720.0
        sun_col = np.array(srgb_to_linear(still.sun.color)) * still.sun.intensity
        for name, v in (("uFwd", view.fwd), ("uRight", view.right), ("uUp", view.up),
                        ("uFogColor", np.array(srgb_to_linear(still.fog_color))),
                        ("uSunDir", still.sun.direction()), ("uScatterColor", sun_col * e.scatter)):
            _set(cp, name, v)
        for name, v in (("uScatterExponent", e.scatter_exponent), ("uBlurSigma", sigma),
                        ("uMaxOpacity", e.max_opacity),
                        ("uBlurExponent", e.blur_exponent)):
            _set(cp, name, v)
        g.color.use(TEX["uColor"])
        g.invdist.use(TEX["uInvDist"])
        fog_tex.use(TEX["uFog"])
        if blur_mode == 2:
            (fa, ta), (fb, tb) = self._linear_targets(t)
            fa.use()
            self.empty_vao[cp].render(moderngl.TRIANGLES, vertices=3)
            bp = self.blur_prog
            _set(bp, "uBlurSigma", sigma)
            _set(bp, "uBlurExponent", e.blur_exponent)
            for src, dst, direction, final in ((ta, fb, (1.0, 0.0), False), (tb, t.out, (0.0, 1.0), True)):
                dst.use()
                src.use(TEX["uImage"])
                _set(bp, "uDirection", direction)
                _set(bp, "uFinal", final)
                self.empty_vao[bp].render(moderngl.TRIANGLES, vertices=3)
        else:
            t.out.use()
            self.empty_vao[cp].render(moderngl.TRIANGLES, vertices=3)

        raw = t.out.read(components=3, alignment=1)
        self.trim(keep_targets=[(w, h)], keep_gbuffers=[(slot, w, h)])
        return np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1]

    def transmittance(self, fog: FogParams, origins, directions, lengths, times) -> np.ndarray:
        """T of each ray by the fog GLSL (float32). Rays are drawn in groups sharing a time
        (the particle state depends on it) and an origin (the layers are packed relative
        to it, as a frame's are to its eye), one draw per group into one target."""
        O = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        W = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        D = np.asarray(lengths, dtype=np.float64).reshape(-1)
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        n = len(D)
        keys = np.column_stack([t, O])
        groups, inverse = np.unique(keys, axis=0, return_inverse=True)
        order = np.argsort(inverse.reshape(-1), kind="stable")   # rays of a group contiguous
        starts = np.searchsorted(inverse.reshape(-1)[order], np.arange(len(groups) + 1))
        rows = -(-n // RAYS_PER_ROW)
        _, rays, _, fbo = self._rays_targets(rows)
        data = np.zeros((rows * RAYS_PER_ROW, 4), np.float32)
        data[:n, :3], data[:n, 3] = W[order], D[order]
        rays.write(data.tobytes(), viewport=(0, 0, RAYS_PER_ROW, rows))
        fbo.use()
        rp = self.rays_program(fog)
        rays.use(TEX["uRays"])
        for g, (tval, *ref) in enumerate(groups):
            lo, hi = int(starts[g]), int(starts[g + 1])
            self._set_fog_uniforms(rp, fog, float(tval), np.array(ref))
            _set(rp, "uFirst", lo)
            _set(rp, "uCount", hi - lo)
            r0, r1 = lo // RAYS_PER_ROW, (hi - 1) // RAYS_PER_ROW + 1
            if r1 - r0 == 1:   # within one row: just its span (no fragments to discard)
                fbo.viewport = (lo % RAYS_PER_ROW, r0, hi - lo, 1)
            else:
                fbo.viewport = (0, r0, RAYS_PER_ROW, r1 - r0)
            self.empty_vao[rp].render(moderngl.TRIANGLES, vertices=3)
        fbo.viewport = (0, 0, RAYS_PER_ROW, rows)
        res = np.frombuffer(fbo.read(viewport=(0, 0, RAYS_PER_ROW, rows), components=1, dtype="f4",
                                     alignment=1), np.float32)
        out = np.empty(n, np.float32)
        out[order] = res[:n]
        return out

    def _rays_targets(self, rows: int):
        """Ray input texture and output target with room for `rows` rows (kept and reused;
        grown by powers of two)."""
        if self._rays_fbo is None or self._rays_fbo[0] < rows:
            cap = 1 << max(0, (rows - 1).bit_length())
            if self._rays_fbo is not None:
                self._park()
                _, old_rays, _, old_fbo = self._rays_fbo
                release_fbo(old_fbo)   # the framebuffer first, then its target texture
                old_rays.release()
            rays = self.ctx.texture((RAYS_PER_ROW, cap), 4, dtype="f4")
            rays.filter = (moderngl.NEAREST, moderngl.NEAREST)
            target = self.ctx.texture((RAYS_PER_ROW, cap), 1, dtype="f4")
            fbo = self.ctx.framebuffer(color_attachments=[target])
            self._rays_fbo = (cap, rays, target, fbo)
        return self._rays_fbo
