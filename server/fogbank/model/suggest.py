"""A new layer that suits the look it joins: placed in front of the camera and thinned
until it cannot white out the view. The page's "Add layer" asks for one
(POST /api/layers/suggest), so that a new layer is visible but never a white-out.

Density-like field per kind (what is halved): `density`, or a potential's `strength`,
a particle layer's `alpha`, distance fog's `max`. The criterion uses the float64
reference (kinds/reference.py): the layer alone, along a 16x9 grid of view rays as long
as the sky's fog runs or to the ground, keeps a median transmittance
of at least 0.6.
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds.reference import layer_transmittance
from fogbank.model.params import LAYER_CLASSES, FogParams
from fogbank.scene import camera as cam
from fogbank.scene import terrain

AHEAD_M = 30.0          # a placed layer's centre: this far along the view (at most; nearer than most objects)
MIN_MEDIAN_T = 0.6      # the layer alone keeps at least this median T over the view (0.4 in frames)
DENSITY_FIELD = {"potential": "strength", "particles": "alpha", "distance": "max"}


def _ground(look: FogParams, x: float, z: float) -> float:
    return float(terrain.height(x, z)) if look.scene == "countryside" else 0.0


def view_rays(look: FogParams, nx: int = 16, ny: int = 9) -> np.ndarray:
    """Unit rays over the view (a 16:9 frame), nx x ny."""
    fwd, right, up = cam.basis(look.camera)
    tan = np.tan(np.radians(look.camera.fov) / 2)
    sx, sy = np.meshgrid(np.linspace(-0.9, 0.9, nx) * tan * 16 / 9, np.linspace(-0.9, 0.9, ny) * tan)
    w = fwd + sx.reshape(-1, 1) * right + sy.reshape(-1, 1) * up
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def ray_lengths(look: FogParams, eye: np.ndarray, w: np.ndarray, step: float = 2.0) -> np.ndarray:
    """How far each ray runs: to the ground (marched in `step` metre steps), or as far as
    the sky's fog runs (sky_distance, at most 4 km, the far plane)."""
    far = min(look.effects.sky_distance, 4000.0)
    s = np.arange(step, far + step, step)
    p = eye[None, None, :] + w[:, None, :] * s[None, :, None]          # rays x steps x 3
    ground = terrain.height(p[..., 0], p[..., 2]) if look.scene == "countryside" else 0.0
    below = p[..., 1] < ground
    hit = below.any(axis=1)
    return np.where(hit, s[np.argmax(below, axis=1)], far)


def suggest_layer(kind: str, look: FogParams) -> dict:
    """The layer of `kind` (a registered kind) with its class's defaults, placed and
    thinned for `look`."""
    cls = LAYER_CLASSES[kind]
    layer = cls().model_dump(mode="json")
    eye = np.asarray(look.camera.position, dtype=np.float64)
    fwd, _, _ = cam.basis(look.camera)
    # in the middle of the view: AHEAD_M along the view ray, or short of where it meets the ground
    reach = float(ray_lengths(look, eye, fwd[None, :])[0])
    ahead = eye + min(AHEAD_M, 0.8 * reach) * fwd
    ground = _ground(look, ahead[0], ahead[2])
    for key in ("center", "emitter"):   # at least its default height above the ground
        if key in layer:
            layer[key] = [float(ahead[0]), max(float(ahead[1]), ground + float(layer[key][1])), float(ahead[2])]
    if kind == "height":   # the fog's base on the ground in front of the camera
        layer["base"] = ground
    field = DENSITY_FIELD.get(kind, "density")
    w = view_rays(look)
    d = ray_lengths(look, eye, w)
    O = np.broadcast_to(eye, w.shape)
    t = np.full(len(w), look.time)
    for _ in range(40):
        T = layer_transmittance(cls.model_validate(layer), look, O, w, d, t)
        if float(np.median(T)) >= MIN_MEDIAN_T:
            break
        layer[field] = float(layer[field]) * 0.5
    return cls.model_validate(layer).model_dump(mode="json")
