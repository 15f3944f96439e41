"""Noise fog (Perlin fog write-up): surface T = exp(-rho d n), or n integrated (volume)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from fogbank.kinds import noise_bake as bake
from fogbank.kinds.kind import Kind, Layout
from fogbank.kinds.rays import slide
from fogbank.model.fields import Bool, Drift, Int, LayerBase, drift_field, num


class Noise(LayerBase):
    """Perlin fog write-up: baked fractal noise n; surface T = exp(-rho d n) or volumetric."""
    model_config = ConfigDict(title="Noise fog")
    kind: Literal["noise"] = "noise"
    source = "Perlin fog (course project write-up)"
    summary = "Patchy fog from fractal Perlin noise baked into a tiling 3D texture, sliding in time."
    formula = r"T = e^{-\rho\, d\, n} \quad \text{or} \quad T = e^{-\rho \int_0^d n(s)\, ds}"
    mode: Literal["surface", "volume"] = "surface"
    density: float = num(0.02, 0, 10, 0.0005, "1/m", "extinction where the noise is 1", title="density ρ")
    scale: float = num(60.0, 0.1, 10000, 0.5, "m", "size of one noise tile", gt=True)
    height_falloff: Bool = Field(True, description="surface mode: n * dY^2 / 2 + 0.001 (write-up)")
    falloff_scale: float = num(10.0, 0.01, 1000, 0.1, "m", "dY is measured in these units", gt=True)
    samples: Int = Field(16, ge=1, le=128, description="volume mode: most samples per ray; each ray "
                                                       "takes what its error bound needs, up to this")
    drift: Drift = drift_field()


def density(layer, x, t, env):
    return layer.density * bake.sample(env.tex, slide(layer, x, t, env.wind), layer.scale)


NOISE_TOL = 1e-3   # kinds/noise.glsl: the volume mode's target error in optical depth


def slope_bound(tex, omega, scale):
    """L: a bound on |dn/ds| along each ray (1/m). Each partial derivative of trilinear
    noise is at most the largest neighbouring-texel step along its axis (bake.steps)."""
    return tex.shape[0] / scale * (np.abs(omega) @ np.asarray(bake.texel_steps(tex)))


def volume_samples(layer, tex, omega, d, weight=1.0, jitter=0.5):
    """Samples per ray: the bound rho L d^2 (j^2 + (1 - j)^2) / (2 S) under NOISE_TOL,
    within [1, layer.samples]; j = `jitter`, each point's share of its interval (0.5, the
    midpoint rule, for rays; a frame's pixel has its own). The shader counts the optical
    depth with the global density (`weight`) inside, and so does this."""
    rho = weight * layer.density
    spread = jitter * jitter + (1.0 - jitter) * (1.0 - jitter)
    need = np.ceil(rho * slope_bound(tex, omega, layer.scale) * d * d * spread / (2.0 * NOISE_TOL))
    return np.clip(need, 1, layer.samples)


def optical_depth(layer, O, omega, d, t, env, jitter=0.5):
    if layer.mode == "volume":
        # the shader's quadrature: its sample count for each ray, each point at the share
        # `jitter` of its interval (0.5 for rays: the midpoint rule)
        jitter = np.broadcast_to(np.asarray(jitter, dtype=np.float64), d.shape)
        n = volume_samples(layer, env.tex, omega, d, env.weight, jitter)
        tau = np.zeros(len(d))
        for i in range(int(n.max(initial=1))):
            x = O + omega * (d * (i + jitter) / n)[:, None]
            tau += np.where(i < n, density(layer, x, t, env), 0.0)
        return env.weight * tau * d / n
    P = O + omega * d[:, None]
    n = bake.sample(env.tex, slide(layer, P, t, env.wind), layer.scale)
    if layer.height_falloff:
        dy = (O[:, 1] - P[:, 1]) / layer.falloff_scale
        n = n * dy * dy / 2.0 + 0.001  # write-up: n = n dY^2 / 2 + 0.001
    return env.weight * layer.density * d * n


def pack(layer, p):
    n = p.fog.noise
    return {"density": p.density * layer.density, "inv_scale": 1.0 / layer.scale,
            "samples": layer.samples,
            "falloff": 1.0 if layer.height_falloff else 0.0,
            "inv_falloff_scale": 1.0 / layer.falloff_scale,
            "offset": np.mod(p.slid(layer) / layer.scale, 1.0),   # E in tiles, mod 1 (float64)
            "steps": bake.steps(n.size, n.octaves, n.blur, n.seed)}


def code(r, variant):
    if variant == ("volume",):
        return r.format("tau += noiseVolumeOpticalDepth(uNoise, Os, w, ds, {density}, {inv_scale}, "
                        "{offset}, {steps}, int({samples}), gSampleJitter);")
    return r.format("tau += noiseSurfaceOpticalDepth(uNoise, Os, P, ds, {density}, {inv_scale}, "
                    "{offset}, {falloff} > 0.5, {inv_falloff_scale});")


def sample(rng):
    return Noise(mode=str(rng.choice(["surface", "volume"])), density=rng.uniform(0, 0.05),
                 scale=rng.uniform(5, 100), height_falloff=bool(rng.random() < 0.5),
                 falloff_scale=rng.uniform(2, 30), samples=int(rng.integers(1, 24)),
                 wind=bool(rng.random() < 0.5),
                 drift=tuple(rng.uniform(-3, 3, 3)) if rng.random() < 0.5 else (0.0, 0.0, 0.0))


# volume mode, per sample along the ray and megapixel of fog target, with the default 64^3
# tile (fog scale 2, 32 and 128 samples: 0.053 at 960x540, 0.068 at 640x360; workers/cost.py
# adds a larger tile's cache misses). It was 0.022, and a still of two such layers
# estimated at 19.7 s took over 30 s (issue 33); tests/gl/test_cost.py holds the corners
NOISE_SAMPLE_S_PER_MPX = 0.07


def extra_seconds(layer, fog_mpx):
    return NOISE_SAMPLE_S_PER_MPX * layer.samples * fog_mpx if layer.mode == "volume" else 0.0


KIND = Kind(
    model=Noise,
    layout=Layout("noise", ("density", 1), ("inv_scale", 1), ("samples", 1),
                  ("falloff", 1), ("inv_falloff_scale", 1), ("offset", 3), ("steps", 3)),
    pack=pack, code=code, sample=sample, optical_depth=optical_depth,
    variant=lambda layer: (layer.mode,), uses_noise=True, seconds_per_mpx=0.05,
    extra_seconds=extra_seconds,
    describe=lambda layer: (f"noise, volume, {layer.samples} samples" if layer.mode == "volume"
                            else "noise"),
)
