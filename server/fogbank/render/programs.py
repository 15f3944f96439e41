"""The compiled programs of one context, cached by their sources, defines and fog layer
variant. A fog program's generated includes come from the kinds registry
(kinds/packing.py); the fixed programs stay, the fog variants are kept to the 48 most
recent."""

from __future__ import annotations

from collections import OrderedDict

from fogbank.kinds.packing import DEFINES, generated
from fogbank.render.gl import TEX, set_uniform
from fogbank.render.glsl import program

FULLSCREEN = "passes/fullscreen.vert"
# Compiled fog programs kept per worker (LRU), each llvmpipe machine code of a few MB. At
# 48, with issue 11's default look (its layers inlined twice, toward the sun), the 60 s
# churn soak's process tree kept growing while the cache filled: 9.9-11.8% after warm-up;
# at 16 it plateaus (1.5%). A look past the 16th recompiles on its first draw.
MAX_VARIANTS = 16


class Programs:
    def __init__(self, ctx):
        self.ctx = ctx
        self._cache: OrderedDict = OrderedDict()
        self.vaos: dict = {}   # program -> its empty vertex array (attribute-less draws)
        self.compiled = 0      # programs made (a frame that made one paid its compile)

    def get(self, vert: str, frag: str, layers: tuple | None = None, inline_particles: bool = True,
            **defines):
        key = (vert, frag, layers, inline_particles, tuple(sorted(defines.items())))
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        gen = generated(layers, inline_particles) if layers is not None else None
        all_defines = {**DEFINES, **defines}
        prog = program(self.ctx, vert, frag, all_defines, gen)
        self.compiled += 1
        prog.extra["inline_particles"] = inline_particles   # which layers its loops cover (bind_fog)
        for name, unit in TEX.items():
            if name in prog.extra["declared"]:
                set_uniform(prog, name, unit)
        self.vaos[prog] = self.ctx.vertex_array(prog, [])
        self._cache[key] = prog
        variants = [k for k in self._cache if k[2] is not None]
        for k in variants[:max(0, len(variants) - MAX_VARIANTS)]:
            old = self._cache.pop(k)
            self.vaos.pop(old).release()
            old.release()
        return prog

    def draw(self, prog, mode, vertices: int = 3, instances: int = 1) -> None:
        """An attribute-less draw (a fullscreen triangle, or instanced quads)."""
        self.vaos[prog].render(mode, vertices=vertices, instances=instances)

    def fog(self, layers: tuple, raymarch_steps: int | None = None, sun: bool = False,
            light: bool = False, stage: int = 0, held_direct: bool = False):
        """The fog pass; particles are left to the quads pass. With raymarch_steps, the
        exponential layers are raymarched instead (the benchmark's comparison); with sun,
        it also integrates each visible point's fog toward the sun; with light, its
        in-scattered light is lit by the light grid (passes/light.frag). `stage` 1 and 2
        split the fog of a still camera in two (passes/fog.frag FOG_STAGE): 1 the sums of
        the layers that do not change with time, 2 the others over them; `held_direct`: the
        held sums include a direct transmittance's (STATIC_DIRECT)."""
        extra = {"RAYMARCH_STEPS": raymarch_steps} if raymarch_steps else {}
        if sun and not raymarch_steps:
            extra["SUN_THROUGH_FOG"] = 1
        if light and stage != 1 and not raymarch_steps:
            extra["LIGHT_GRID"] = 1
        if stage:
            extra["FOG_STAGE"] = stage
        if held_direct:
            extra["STATIC_DIRECT"] = 1
        return self.get(FULLSCREEN, "passes/fog.frag", layers, inline_particles=False,
                        **extra)

    def light(self, layers: tuple, slices: int, shadow_taps: int, lit: bool, stage: int = 0):
        """The light grid's march (passes/light.frag) for a fog of these layers (particles
        are lit by their quads): `slices` slices a column, `shadow_taps` shadow-map samples
        a slice (0: no shadows), with `lit` the fog toward the sun; `stage` 1 and 2 split a
        still camera's (LIGHT_STAGE)."""
        extra = {"SUN_THROUGH_FOG": 1} if lit else {}
        return self.get(FULLSCREEN, "passes/light.frag", layers, inline_particles=False, SLICES=slices,
                        SHADOW_TAPS=shadow_taps, LIT=int(lit), LIGHT_STAGE=stage, **extra)
