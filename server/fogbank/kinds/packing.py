"""Packs a fog's layers into the uniforms of render/shaders/fog/transmittance.glsl, and
writes the GLSL that includes and calls each kind's function (fog/kinds.gen.glsl,
fog/layers.gen.glsl, fog/density.gen.glsl). Everything kind-specific comes from the
registry (kinds/__init__.py): each kind's layout, pack and code.

One layer is LAYER_VEC4 vec4s of uLayer. Particle positions go to a texture. The
generated calls depend only on `variant(fog)` (the kinds and each kind's variant, e.g.
a cosine layer's term count), so one compiled program serves every value of the
parameters; the renderer caches programs by that key. Positions, phases and tile
offsets are packed relative to a reference point (the eye) and slid by the wind in
float64 (docs/accuracy.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fogbank.kinds import KINDS
from fogbank.kinds.box import CARVE_SHELLS
from fogbank.kinds.kind import LAYER_VEC4, Packing
from fogbank.kinds.rays import velocity
from fogbank.model.fields import MAX_LAYERS, MAX_PARTICLES

DEFINES = {"MAX_LAYERS": MAX_LAYERS, "LAYER_VEC4": LAYER_VEC4, "CARVE_SHELLS": CARVE_SHELLS}
FLT_MIN = float(np.finfo(np.float32).tiny)


def enabled(fog) -> list[tuple[int, object]]:
    """(index in fog.layers, layer) of the enabled layers: slot n of uLayer holds the n-th."""
    return [(i, layer) for i, layer in enumerate(fog.layers) if layer.enabled]


def changes_with_time(layer, fog) -> bool:
    """Whether a layer's part of the fog changes with the look's time: its density slides
    (wind-sensitive under a wind, or its own drift) or comes from a simulation (particles).
    Every other layer's packed values are the same at every time (pack_layers)."""
    return KINDS[layer.kind].simulate is not None or bool(velocity(layer, fog.wind.vector()).any())


def split_by_time(fog) -> tuple:
    """The look as two: its enabled layers that do not change with time, and the others
    (each a copy of the look with only those layers, in their order). A layer that changes
    with time but whose kind can split it (Kind.split_by_time: a cosine's terms across the
    wind) gives each part its share. A carving body that stays goes with both parts; one
    that moves makes every layer move."""
    parts: tuple[list, list] = ([], [])
    carving = [layer for _, layer in enabled(fog) if carves((layer.kind, KINDS[layer.kind].variant(layer)))]
    if any(changes_with_time(layer, fog) for layer in carving):
        # a moving carving body changes how much it takes from every other layer: all move
        return fog.model_copy(update={"layers": []}), fog.model_copy(update={"layers": [l for _, l in enabled(fog)]})
    for _, layer in enabled(fog):
        split = KINDS[layer.kind].split_by_time
        if layer in carving:
            # a still carving body takes its share of each part's layers: it goes with both
            # (the share is linear in the other layers' depth)
            parts[0].append(layer)
            parts[1].append(layer)
        elif not changes_with_time(layer, fog):
            parts[0].append(layer)
        elif split is None:
            parts[1].append(layer)
        else:
            for part, share in zip(parts, split(layer, velocity(layer, fog.wind.vector()))):
                if share is not None:
                    part.append(share)
    if all(layer in carving for layer in parts[1]):   # nothing moves: nothing for the bodies to carve there
        parts[1].clear()
    return tuple(fog.model_copy(update={"layers": part}) for part in parts)


def variant(fog) -> tuple:
    """What the generated GLSL depends on: per enabled layer, its kind and its kind's
    variant (cosine: the term count; noise: the mode). Particle layers keep their slot
    (their data is packed there) whether or not the shader loops over them."""
    return tuple((layer.kind, KINDS[layer.kind].variant(layer)) for _, layer in enabled(fog))


def kinds_code() -> str:
    """fog/kinds.gen.glsl: every registered kind's GLSL file."""
    return "".join(f'#include "{k.glsl_file}"\n' for k in KINDS.values())


def groups(key: tuple) -> list[tuple[tuple, list[int]]]:
    """The layers' slots grouped by kind and variant, in order of first appearance."""
    out: dict[tuple, list[int]] = {}
    for n, kv in enumerate(key):
        out.setdefault(kv, []).append(n)
    return list(out.items())


def loop_tables(key: tuple, inline_particles: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """uLayerSlots and uGroupCounts (MAX_LAYERS floats each) for layer_code's loops: the
    slots of each looped group one after the other, and each looped group's size."""
    slots = np.zeros(MAX_LAYERS, np.float32)
    counts = np.zeros(MAX_LAYERS, np.float32)
    pos = 0
    for g, (_, members) in enumerate(_looped(key, inline_particles)):
        slots[pos:pos + len(members)] = members
        counts[g] = len(members)
        pos += len(members)
    return slots, counts


def _looped(key: tuple, inline_particles: bool) -> list[tuple[tuple, list[int]]]:
    return [(kv, m) for kv, m in groups(key)
            if len(m) > 1 and KINDS[kv[0]].loop and (inline_particles or not KINDS[kv[0]].quads)]


def carves(kv: tuple) -> bool:
    """A layer variant that carves (kinds/carving.py): its code is fog/carve.gen.glsl's."""
    return "carve" in kv[1]


def layer_code(key: tuple, inline_particles: bool = True) -> str:
    """fog/layers.gen.glsl for a variant key. With inline_particles False, kinds drawn by
    their own pass (particles: the quads pass) are left out.

    Layers of one kind and variant, wherever they sit among the others, are one loop over
    their slots, its body the kind's code once: llvmpipe's compile time grows faster than
    the program (16 cosine layers of 8 terms inlined took 43 s to compile, past the
    stream's frame deadline; 16 boxes over 40 s; 16 volume-noise layers over 60 s), and a
    loop keeps the program the size of its distinct kinds. The slots and the trip counts
    are read from uniforms (uLayerSlots, uGroupCounts; loop_tables), not written in, so
    that the compiler does not unroll the loops back into the inlined program. Kinds whose
    code is tiny (Kind.loop False) stay inline. Every layer adds to the same sums (tau,
    tauDirect), so their order does not matter beyond rounding."""
    looped = dict(_looped(key, inline_particles))
    lines = []
    pos = g = 0
    for n, kv in enumerate(key):
        name, v = kv
        kind = KINDS[name]
        label = f"{name} {' '.join(map(str, v))}".rstrip()
        if kind.quads and not inline_particles:
            lines.append(f"// layer {n}: {name}, drawn by its own pass")
        elif carves(kv):
            lines.append(f"// layer {n}: {label}, carving (fog/carve.gen.glsl)")
        elif kv not in looped:
            lines.append(f"// layer {n}: {label}")
            lines.append(kind.code(kind.layout.refs(n * LAYER_VEC4), v))
        elif looped[kv][0] == n:   # the loop, where its first layer sits
            members = looped[kv]
            lines.append(f"// layers {', '.join(map(str, members))}: {label}")
            lines.append(f"for (int i = {pos}; i < {pos} + int(uGroupCounts[{g // 4}].{'xyzw'[g % 4]}); ++i) {{")
            lines.append(f"int layerBase = {LAYER_VEC4} * int(uLayerSlots[i / 4][i % 4]);")
            lines.append(kind.code(kind.layout.refs("layerBase"), v))
            lines.append("}")
            pos += len(members)
            g += 1
    return "\n".join(lines) + "\n"


def carve_code(key: tuple) -> str:
    """fog/carve.gen.glsl: the carving layers (kinds/carving.py). Each takes its strength's
    share of the other density layers' optical depth over each of its shells' chords, written
    without subtracting two large sums (a ray inside a body of dense fog would keep only
    float32's rounding of it): tau (1 - sum of strengths) plus each body's strength / K times
    the others' depth outside each shell's chord ([0, s0] and [s1, d]: exactly the part
    each shell leaves), one call of fogPlainDepths per piece. Several carving layers of one
    kind are one loop over their slots (as layer_code's loops: one copy of fogPlainDepths)."""
    lines = []
    for kv, members in groups(key):
        if not carves(kv):
            continue
        kind = KINDS[kv[0]]
        base = "carveBase" if len(members) > 1 else members[0] * LAYER_VEC4
        chord, shells, strength = kind.carve_code(kind.layout.refs(base), kv[1])
        body = (f"int shells = {shells};\n"
                f"carveStrength += {strength};\n"
                f"for (int k = 0; k < shells; ++k) {{\n"
                f"    vec2 ch = {chord};\n"
                f"    float kept = plainTau;   // the shell missed: all of the ray is outside it\n"
                f"    if (ch.y > ch.x) {{\n"
                f"        kept = 0.0;\n"
                f"        for (int j = 0; j < 2; ++j) {{   // [0, s0] and [s1, d]: one call site\n"
                f"            float a = j == 0 ? 0.0 : ch.y, b = j == 0 ? ch.x : ds;\n"
                f"            if (b > a) kept += fogPlainDepths(Os + w * a, w, b - a).x;\n"
                f"        }}\n"
                f"    }}\n"
                f"    carveKept += {strength} / float(shells) * kept;\n"
                f"}}")
        lines.append(f"// layers {', '.join(map(str, members))}: {kv[0]}, carving")
        if len(members) > 1:
            slots = ", ".join(f"{LAYER_VEC4 * m}.0" for m in members)
            lines.append(f"float carveSlots[{len(members)}] = float[{len(members)}]({slots});")
            lines.append(f"for (int c = 0; c < {len(members)}; ++c) {{")
            lines.append("int carveBase = int(carveSlots[c]);")
            lines.append(body)
            lines.append("}")
        else:
            lines.append("{")
            lines.append(body)
            lines.append("}")
    return "\n".join(lines) + "\n"


def density_code(key: tuple) -> str:
    """fog/density.gen.glsl (used only when RAYMARCH_STEPS is defined): the summed density
    at x of the layers whose kind has a GLSL density."""
    lines = []
    # the carving bodies last: they scale what the others' densities sum to
    for n, (name, v) in sorted(enumerate(key), key=lambda nv: carves(nv[1])):
        kind = KINDS[name]
        if kind.density_code is None:
            lines.append(f"// layer {n}: {name} has no raymarched form")
        else:
            lines.append(kind.density_code(kind.layout.refs(n * LAYER_VEC4), v))
    return "\n".join(lines) + "\n"


def generated(key: tuple, inline_particles: bool = True) -> dict[str, str]:
    """The generated includes of a fog program for a variant key."""
    return {"fog/kinds.gen.glsl": kinds_code(),
            "fog/layers.gen.glsl": layer_code(key, inline_particles),
            "fog/carve.gen.glsl": carve_code(key),
            "fog/density.gen.glsl": density_code(key)}


def direct_density(fog) -> float:
    """uDensity, the weight of the direct transmittances' logarithms (T_j^density =
    exp(density log T_j)): a positive density too small for float32 is sent as its
    smallest normal number (T^tiny is 1 to float32; an opaque T_j = 0 stays 0 whatever
    the density, render/shaders/common/math.glsl directDepth)."""
    return max(fog.density, FLT_MIN) if fog.density > 0 else 0.0


def pack(fog, particle_states: dict[int, tuple[np.ndarray, ...]],
         ref=(0.0, 0.0, 0.0), time: float = 0.0):
    """Returns (uLayer data float32 (MAX_LAYERS*LAYER_VEC4, 4), particles float32
    (MAX_PARTICLES, 4)) for the enabled layers, in the order of `variant(fog)`."""
    packed = pack_layers(fog, particle_states, ref, time)
    return packed.data, packed.particles


@dataclass
class Packed:
    data: np.ndarray          # uLayer, float32 (MAX_LAYERS * LAYER_VEC4, 4)
    particles: np.ndarray     # the particle texture's row, float32 (MAX_PARTICLES, 4)
    radii: np.ndarray         # each particle row's radius (m), float32 (MAX_PARTICLES,)
    values: list[dict]        # each enabled layer's slot values (float64), in slot order
    kinds: list[str]          # each enabled layer's kind, in slot order


def pack_layers(fog, particle_states: dict[int, tuple[np.ndarray, ...]],
                ref=(0.0, 0.0, 0.0), time: float = 0.0) -> Packed:
    """The enabled layers packed into uLayer by each kind's declared slots.

    Everything that depends on where or when is taken here in float64, relative to the
    reference point `ref` (the eye of a frame, the origin of a group of rays) and slid by
    wind * `time`: centres become offsets from ref, phases and tile offsets are reduced to
    one period. The shader then works near 0, where float32 is at its finest, whatever the
    eye's distance from the origin or the time (docs/accuracy.md). The global density
    multiplies every exponential layer's density here (into the logarithm for height fog),
    so that a tiny global density over a huge optical depth is not lost to float32."""
    data = np.zeros((MAX_LAYERS * LAYER_VEC4, 4), np.float64)
    p = Packing(fog=fog, ref=np.asarray(ref, dtype=np.float64), time=time, density=fog.density,
                states=particle_states, particles=np.zeros((MAX_PARTICLES, 4), np.float64),
                radii=np.ones(MAX_PARTICLES, np.float64))
    values, kinds = [], []
    for n, (i, layer) in enumerate(enabled(fog)):
        kind = KINDS[layer.kind]
        p.index = i
        v = kind.pack(layer, p)
        kind.layout.write(data[n * LAYER_VEC4:(n + 1) * LAYER_VEC4], v)
        values.append(v)
        kinds.append(layer.kind)
    return Packed(data.astype(np.float32), p.particles.astype(np.float32), p.radii.astype(np.float32), values,
                  kinds)


def uses_noise(fog) -> bool:
    """Whether an enabled layer samples the baked noise."""
    return any(KINDS[layer.kind].uses_noise for _, layer in enabled(fog))
