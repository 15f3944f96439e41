"""What a fog layer kind is, and the one place its parts meet.

A kind is one Python module plus its GLSL file in this folder, registered by one line in
kinds/__init__.py. The module declares a `Kind`: its params model, its packing (named
slots of the per-layer uniform block, with a budget checked here at import), the GLSL
call that adds its optical depth, its float64 reference and a scene-scale draw for the
tests. Everything else (the params union, the URL codec, the JSON Schema, the generated
GLSL, the packing, the cost estimate, the test draws) reads the registry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from fogbank.kinds.rays import velocity

# The per-layer uniform budget: LAYER_VEC4 vec4s of uLayer per layer. MAX_LAYERS x
# LAYER_VEC4 = 192 vec4s, under the 256 fragment uniform vec4s GL 3.3 guarantees
# (GL_MAX_FRAGMENT_UNIFORM_COMPONENTS >= 1024) with room for the passes' own uniforms.
LAYER_VEC4 = 12
SWIZZLE = "xyzw"
RESERVED = frozenset({"base", "at", "group", "format"})   # Refs' own attributes


class SlotError(ValueError):
    """A kind's layout or packing breaks its declaration (raised at import or pack)."""


@dataclass(frozen=True)
class Slot:
    """`size` floats (1..4) at vec4 `vec` + component `comp`; an array of `count` of them
    when count > 1 (vec4 arrays one per vec4, float arrays four per vec4)."""
    name: str
    size: int
    count: int
    vec: int
    comp: int

    def ref(self, base: int | str, j: int | None = None) -> str:
        """The GLSL expression reading this slot (element j of an array) of the layer whose
        first uLayer index is `base`: a number, or a GLSL int expression (a loop over
        layers of one kind, kinds/packing.py layer_code)."""
        def at(k: int) -> str:
            return f"uLayer[{base + k}]" if isinstance(base, int) else f"uLayer[{base} + {k}]"
        if self.count > 1:
            if j is None:
                raise SlotError(f"slot {self.name!r} is an array: give an index")
            if self.size == 4:
                return at(self.vec + j)
            return f"{at(self.vec + j // 4)}.{SWIZZLE[j % 4]}"
        if self.size == 4:
            return at(self.vec)
        return f"{at(self.vec)}.{SWIZZLE[self.comp:self.comp + self.size]}"


class Layout:
    """Named slots packed in declaration order: a single slot goes where it fits in the
    current vec4 without crossing into the next; arrays start on a fresh vec4. The total
    is checked against LAYER_VEC4 at import (a SlotError names the kind)."""

    def __init__(self, kind: str, *slots: tuple):
        self.kind = kind
        self.slots: dict[str, Slot] = {}
        vec, comp = 0, 0
        for spec in slots:
            name, size, count = (*spec, 1) if len(spec) == 2 else spec
            if name in RESERVED or name.startswith("_") or not name.isidentifier():
                raise SlotError(f"kind {kind!r}: {name!r} cannot name a slot (reserved: "
                                f"{', '.join(sorted(RESERVED))})")
            if not 1 <= size <= 4 or count < 1 or (count > 1 and size not in (1, 4)):
                raise SlotError(f"kind {kind!r}: slot {name!r} has size {size} x {count}; "
                                "a slot is 1-4 floats, an array is of floats or vec4s")
            if count > 1 or comp + size > 4:
                vec, comp = (vec + 1, 0) if comp else (vec, 0)
            self.slots[name] = Slot(name, size, count, vec, comp)
            if count > 1:
                vec += count if size == 4 else -(-count // 4)
                comp = 0
            else:
                comp += size
                if comp == 4:
                    vec, comp = vec + 1, 0
        self.vec4s = vec + (1 if comp else 0)
        if self.vec4s > LAYER_VEC4:
            raise SlotError(f"kind {kind!r} needs {self.vec4s} vec4s per layer; the budget is "
                            f"LAYER_VEC4 = {LAYER_VEC4}")

    def refs(self, base: int) -> "Refs":
        return Refs(self, base)

    def write(self, block: np.ndarray, values: dict[str, Any]) -> None:
        """Write every slot's value into one layer's (LAYER_VEC4, 4) float64 block. Every
        declared slot must be given, and nothing else."""
        missing, extra = set(self.slots) - set(values), set(values) - set(self.slots)
        if missing or extra:
            raise SlotError(f"kind {self.kind!r} packed {sorted(values)}; its slots are "
                            f"{sorted(self.slots)}")
        flat = block.reshape(-1)
        for name, value in values.items():
            s = self.slots[name]
            v = np.asarray(value, dtype=np.float64).reshape(-1)
            if s.count > 1:
                if len(v) > s.count * s.size:
                    raise SlotError(f"kind {self.kind!r}: slot {name!r} holds {s.count} x {s.size}, "
                                    f"got {len(v)} values")
                flat[s.vec * 4:s.vec * 4 + len(v)] = v
            else:
                if len(v) != s.size:
                    raise SlotError(f"kind {self.kind!r}: slot {name!r} holds {s.size}, got {len(v)}")
                flat[s.vec * 4 + s.comp:s.vec * 4 + s.comp + s.size] = v


class Refs:
    """Slot references for one layer's GLSL: `refs.center` is e.g. "uLayer[13].xyz",
    `refs.at("terms", j)` element j of an array. `format(template)` fills `{slot}`s."""

    def __init__(self, layout: Layout, base: int):
        self._layout, self.base = layout, base

    def __getattr__(self, name: str) -> str:
        try:
            return self._layout.slots[name].ref(self.base)
        except KeyError:
            raise SlotError(f"kind {self._layout.kind!r} has no slot {name!r}") from None

    def at(self, name: str, j: int) -> str:
        return self._layout.slots[name].ref(self.base, j)

    def group(self, name: str, k: int) -> str:
        """The k-th whole vec4 of a float array slot (four of its elements)."""
        s = self._layout.slots[name]
        if s.count == 1 or s.size != 1 or not 0 <= k < -(-s.count // 4):
            raise SlotError(f"kind {self._layout.kind!r}: slot {name!r} has no vec4 {k}")
        return s.ref(self.base, 4 * k).split(".")[0]

    def format(self, template: str) -> str:
        return template.format(**{n: s.ref(self.base) for n, s in self._layout.slots.items()
                                  if s.count == 1})


@dataclass
class Packing:
    """What a kind's `pack` may read: the look, the reference point E (float64, the eye or
    a group of rays' origin), the time, the global density folded into exponential
    layers, and the particle texture's rows (particles only)."""
    fog: Any
    ref: np.ndarray
    time: float
    density: float
    states: dict
    particles: np.ndarray
    radii: np.ndarray       # each particle row's radius, m (row 1's second channel)
    first_particle: int = 0
    index: int = -1        # the layer's index in fog.layers (its particle state's key)

    def wind(self, layer) -> np.ndarray:
        """The velocity the layer's density slides with: the wind for a wind-sensitive
        layer, plus the layer's own drift (kinds/rays.velocity)."""
        return velocity(layer, self.fog.wind.vector())

    def slid(self, layer) -> np.ndarray:
        """E in the layer's own (unslid) frame: rho(x - wind t) is rho at x - wind t."""
        return self.ref - self.wind(layer) * self.time


@dataclass
class Env:
    """What a float64 reference may read besides the layer and the rays: the wind velocity,
    the global density `weight`, the baked noise tile and a particle state."""
    wind: np.ndarray
    weight: float = 1.0
    tex: Any = None
    state: Any = None


def exponential(template: str) -> Callable:
    """GLSL for a kind whose layer adds an optical depth: `tau += <template>;`."""
    return lambda refs, variant: f"tau += {refs.format(template)};"


def direct(template: str) -> Callable:
    """GLSL for a kind whose layer has a transmittance T_j (not an exponential of a linear
    optical depth), given as its opacity 1 - T_j: it adds density * -log T_j
    (common/math.glsl directDepth) to tauDirect, which no carving body reduces."""
    return lambda refs, variant: f"tauDirect += directDepth({refs.format(template)}, uDensity);"


@dataclass(frozen=True)
class Kind:
    model: type                            # the params model (pydantic, kind: Literal[...])
    layout: Layout                         # named slots of the per-layer uniform block
    pack: Callable[[Any, Packing], dict]   # layer -> {slot: values}, float64
    code: Callable[[Refs, tuple], str]     # GLSL statements adding the layer to `tau`
    sample: Callable[[np.random.Generator], Any]   # a scene-scale draw (tests, benches)
    # float64 reference: exactly one of optical_depth (exponential kinds) and
    # log_transmittance (direct kinds), each (layer, O, omega, d, t, env) over N rays
    optical_depth: Callable | None = None
    log_transmittance: Callable | None = None
    density: Callable | None = None        # float64 density (layer, x, t, env), if it has one
    density_code: Callable[[Refs, tuple], str] | None = None   # GLSL `rho += ...` (raymarch)
    # a body that can carve (kinds/carving.py): GLSL (its shell k's chord as a vec2 of
    # absolute parameters, given int k and int shells; how many shells; its strength), and
    # its float64 nested shells' chords along rays, [(share, s0, s1)]
    carve_code: Callable[[Refs, tuple], tuple[str, str, str]] | None = None
    shell_chords: Callable | None = None
    variant: Callable[[Any], tuple] = lambda layer: ()         # what the GLSL depends on
    cpu_only: frozenset = frozenset()      # fields that never reach the GPU data (by design)
    uses_noise: bool = False               # samples the baked noise tile
    quads: bool = False                    # drawn by its own pass, not in the fog pass
    # a kind whose GPU data comes from a CPU simulation: (layer, time, fog) -> its state,
    # handed to `pack` as packing.states[layer index]; and its cost in seconds
    simulate: Callable | None = None
    simulate_seconds: Callable[[Any], float] = lambda layer: 0.0
    seconds_per_mpx: float = 0.04          # fog pass cost per megapixel (reference machine)
    extra_seconds: Callable[[Any, float], float] = lambda layer, fog_mpx: 0.0
    describe: Callable[[Any], str] = lambda layer: layer.kind
    jit_units: Callable[[tuple], float] = lambda variant: 1.0
    # A layer that changes with time as two layers whose optical depths add up to its own:
    # the part that does not change, and the part that does (either None), given the
    # velocity its density slides with (kinds/packing.py split_by_time); None: the whole
    # layer changes
    split_by_time: Callable[[Any, np.ndarray], tuple] | None = None
    # Several layers of this kind are one loop in the fog program (kinds/packing.py
    # layer_code): False for kinds whose code is so small that 16 inlined copies compile
    # about as fast, where the loop's dynamic uniform reads would only cost every frame
    # (fog pass of 16 layers at 480x270: homogeneous 4.0 ms inlined, 15.8 looped; sphere
    # 9.7 and 19.4)
    loop: bool = True

    @property
    def name(self) -> str:
        return self.model.model_fields["kind"].default

    @property
    def glsl_file(self) -> str:
        return f"kinds/{self.name}.glsl"   # beside its module

    def __post_init__(self) -> None:
        if (self.optical_depth is None) == (self.log_transmittance is None):
            raise SlotError(f"kind {self.name!r}: give exactly one float64 reference, "
                            "optical_depth or log_transmittance")
        if self.layout.kind != self.name:
            raise SlotError(f"kind {self.name!r} declares the layout of {self.layout.kind!r}")
