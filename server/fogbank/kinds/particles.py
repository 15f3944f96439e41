"""Particle fog (Fischer): T = prod_j (1 - alpha s_j clamp(1 - dist_j / R_j, 0, 1)), each
particle's radius R_j growing over its life from R to `growth` R (R_j = R: Fischer's)."""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field, PrivateAttr, model_validator

from fogbank.kinds.kind import Kind, Layout
from fogbank.model.fields import MAX_PARTICLES, Direction, Int, LayerBase, Position, num, with_rules


Spread = Annotated[float, Field(strict=True, ge=0.0, le=1000.0)]


class Particles(LayerBase):
    """Fischer: a few free-floating particles; T = prod (1 - alpha s_j clamp(1 - dist_j/R, 0, 1))."""
    # x-rules: the validator's cross-field rule for the page (static/controls.js keepRules)
    model_config = ConfigDict(title="Particles", json_schema_extra=with_rules(
        {"field": "life_max", "atLeast": {"field": "life_min"}, "why": "the longest life is at least the shortest"}))
    kind: Literal["particles"] = "particles"
    source = "Fischer, Clouds, Fog, and Smoke"
    summary = "A few free-floating particles born at an emitter and carried by the wind: drifting fog or smoke."
    formula = r"T = \prod_j \left(1 - \alpha\, s_j\, \mathrm{clamp}\left(1 - \frac{d_j}{R}, 0, 1\right)\right)"
    count: Int = Field(120, ge=1, le=MAX_PARTICLES, description="particles alive at once (slots)")
    emitter: Position = Field((10.0, 2.0, 0.0), description="where particles are born, m")
    emitter_size: tuple[Spread, Spread, Spread] = Field(
        (0.0, 0.0, 0.0), description="half-extents of the box round the emitter where particles "
                                     "are born, uniformly (0: a point), m")
    direction: Direction = Field((0.0, 1.0, 0.0), description="mean launch direction")
    spread: float = num(25.0, 0, 180, 1, "deg", "cone half-angle around direction")
    speed: float = num(1.5, 0, 50, 0.1, "m/s", "launch speed")
    life_min: Int = Field(64, ge=1, le=1000, description="shortest life, steps")
    life_max: Int = Field(128, ge=1, le=1000, description="longest life, steps")
    step: float = num(0.1, 0.005, 10, 0.005, "s", "simulation step", gt=True)
    radius: float = num(4.0, 0.01, 100, 0.1, "m", "one particle's radius R (at birth)", gt=True, title="radius R")
    growth: float = num(1.0, 1.0, 10.0, 0.1, "", "a particle's radius at the end of its life, in R, grown "
                        "linearly with age: smoke that widens as it rises (1: Fischer's constant radius)",
                        title="growth")
    alpha: float = num(0.2, 0, 1, 0.01, "", "max opacity of one particle (0.2 fog, ~1 smoke)", title="opacity α")
    gravity: float = num(0.0, -20, 20, 0.1, "m/s^2", "upward acceleration (negative falls)")
    drag: float = num(0.5, 0, 10, 0.05, "1/s", "relaxation of velocity toward the wind")
    seed: Int = Field(1, ge=0, le=2**31 - 1, description="random seed")
    # Drawn: every `_stride`-th particle alive, each that much more opaque (a stream's
    # preview, stream/session.py _detailed). Not a field: the simulation, its caches and the
    # URL see the whole layer, so a preview's swarm is the full one's, thinned, and changing
    # the preview's detail simulates nothing again (a new count was a new swarm, integrated
    # from its birth: ~200 ms for particles of life 1000).
    _stride: int = PrivateAttr(1)

    @model_validator(mode="after")
    def _life(self) -> "Particles":
        if self.life_min > self.life_max:
            raise ValueError(f"life_min = {self.life_min} must be <= life_max = {self.life_max}")
        return self

    def thinned(self, stride: int) -> "Particles":
        """This layer drawn with every `stride`-th particle alive, each `stride` times as
        opaque (at most 1): the swarm's optical depth kept, its grain coarser."""
        out = self.model_copy()
        out._stride = max(1, int(stride))
        return out

    @property
    def drawn(self) -> int:
        """At most how many particles are drawn (count, thinned)."""
        return -(-self.count // self._stride)


def segment_distance(p, O, omega, d):
    """Distance from points p (M, 3) to each segment O -> O + omega d: (N, M). Fischer/Bourke:
    project onto the line, clamp the parameter to [0, d]."""
    rel = p[None, :, :] - O[:, None, :]
    u = np.clip(np.einsum("nmk,nk->nm", rel, omega), 0.0, d[:, None])
    closest = rel - u[:, :, None] * omega[:, None, :]
    return np.linalg.norm(closest, axis=2)


def radii(layer, age: np.ndarray) -> np.ndarray:
    """Each particle's radius R_j (m) from its age over its life, in [0, 1): R at birth,
    growing linearly to `growth` R. A smoke puff widens as it rises and mixes with the air;
    its strength (Fischer's remaining life) already thins it as it goes."""
    return layer.radius * (1.0 + (layer.growth - 1.0) * np.asarray(age, dtype=np.float64))


def log_transmittance_of(layer, state, O, omega, d):
    """log T, summed over particles as logarithms (a product of many clarities underflows
    float64: 900 of 0.25 is 1e-538), -inf where a particle is opaque. `state`: positions,
    strengths and ages over life (simulate_state)."""
    pos, strength, age = state
    if len(pos) == 0:
        return np.zeros(len(d))
    dist = segment_distance(pos, O, omega, d)
    opacity = layer.alpha * strength[None, :] * np.clip(1.0 - dist / radii(layer, age)[None, :], 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return np.sum(np.log1p(-opacity), axis=1)


def transmittance(layer, state, O, omega, d):
    return np.exp(log_transmittance_of(layer, state, O, omega, d))


def pack(layer, p):
    # the particles' positions relative to E go to the particle texture, from this
    # layer's first row; the block says where they are. Farthest from E first: the quads
    # pass composites each particle's light over what lies behind it, back to front
    # (render/shaders/passes/particles.frag); a product of clarities has no order.
    pos, strength, age = p.states[p.index]
    k = layer._stride
    pos, strength, age = pos[::k], strength[::k], age[::k]
    order = np.argsort(-np.linalg.norm(pos - p.ref, axis=1), kind="stable")
    pos, strength, age = pos[order], strength[order], age[order]
    first, count = p.first_particle, len(pos)
    p.particles[first:first + count, :3] = pos - p.ref
    p.particles[first:first + count, 3] = strength
    p.radii[first:first + count] = radii(layer, age)
    p.first_particle += count
    return {"alpha": min(1.0, layer.alpha * k), "first": first, "count": count}


def code(r, variant):
    # one particle per texel of uParticles (row 0: position and strength; row 1's second
    # channel: its radius); the fog pass leaves this to the quads pass
    return (f"for (int j = 0; j < int({r.count}); ++j) {{ "
            f"vec4 q = texelFetch(uParticles, ivec2(int({r.first}) + j, 0), 0); "
            f"float Rj = texelFetch(uParticles, ivec2(int({r.first}) + j, 1), 0).g; "
            f"tauDirect += directDepth(particleOpacity(Os, w, ds, q.xyz, Rj, q.w, {r.alpha}), "
            f"uDensity); }}")


def reference(layer, O, omega, d, t, env):
    return log_transmittance_of(layer, env.state, O, omega, d)


def sample(rng):
    size = tuple(rng.uniform(0, 20, 3)) if rng.random() < 0.5 else (0.0, 0.0, 0.0)
    return Particles(count=int(rng.integers(1, 200)), emitter=tuple(rng.normal(size=3) * 5), emitter_size=size,
                     direction=tuple(rng.normal(size=3)), spread=rng.uniform(0, 90),
                     speed=rng.uniform(0, 3), radius=rng.uniform(1, 8), alpha=rng.uniform(0, 1),
                     growth=1.0 if rng.random() < 0.5 else rng.uniform(1, 4),
                     life_min=8, life_max=int(rng.integers(8, 64)), step=rng.uniform(0.05, 0.5),
                     seed=int(rng.integers(0, 1000)), wind=bool(rng.random() < 0.5))


PARTICLE_S_PER_MPX = 0.0011      # one particle quad of radius 20 m, per megapixel
PARTICLE_SIM_S = 0.5             # simulating 1024 particles of life 128 steps, once per time


def simulate_state(layer, time: float, fog):
    """Fischer's particles at `time` over the look's ground (kinds/particle_motion.py):
    positions, strengths and ages over life."""
    from fogbank.kinds.particle_motion import simulate
    from fogbank.scene import terrain
    ground = terrain.flat if fog.scene == "calibration" else terrain.height
    return simulate(layer, time, fog.wind.vector(), ground, ages=True)


def sim_seconds(layer) -> float:
    return PARTICLE_SIM_S * layer.count / 1024 * layer.life_max / 128


def extra_seconds(layer, fog_mpx):
    # a particle's quad at its mean radius over life, (1 + growth) / 2 R
    cover = min(max((layer.radius * (1.0 + layer.growth) / 2.0 / 20.0) ** 2, 0.05), 16.0)
    return PARTICLE_S_PER_MPX * layer.drawn * cover * fog_mpx + sim_seconds(layer)


KIND = Kind(
    model=Particles,
    layout=Layout("particles", ("alpha", 1), ("first", 1), ("count", 1)),
    pack=pack, code=code, sample=sample, log_transmittance=reference,
    quads=True, seconds_per_mpx=0.0, extra_seconds=extra_seconds,
    simulate=simulate_state, simulate_seconds=sim_seconds,
    describe=lambda layer: f"particles, {layer.count} of radius {layer.radius:g} m"
                           + (f" growing to {layer.radius * layer.growth:g} m" if layer.growth != 1.0 else ""),
    jit_units=lambda variant: 0.0,
)
