"""The calibration scene's reference picture (tests/gl): every interior pixel is the blend
of its object's known colour and the fog colour by the float64 reference T along a ray of
the hand-written camera (tests/hand.py), cast analytically."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.reference import transmittance as reference
from fogbank.model.fields import srgb_to_linear
from fogbank.model.params import StillParams
from fogbank.scene import camera as cam
from fogbank.scene import meshes as scenes
from hand import cast, hand_rays

W, H = 320, 180

# Near the edge of the domain, 12.7 km from the origin: the sky's fog comes from layers
# placed by the eye, held and drifting with the wind at a late time (t = 3.7e5 s); only
# the sky (-1) is checked. The view's lower edge is 1 degree above the horizon: the
# calibration ground (+-2 km) lies 10.5 km off, within the far plane, and a strip of it
# thinner than a pixel row there covers samples of pixels whose centres see the sky.
FAR_CAMERA = ({"position": (9000.0, 30.0, -9000.0), "yaw": -90.0, "pitch": 31.0, "fov": 60.0},
              [{"kind": "sphere", "center": (8940.0, 34.0, -9003.0), "radius": 25.0, "density": 0.03},
               {"kind": "cosine", "density": 0.004, "c0": 1.0, "scale": 3.0, "wind": True,
                "terms": [{"amp": 0.9, "k": (0.3, 1.1, 0.2), "phase": 0.5}]},
               {"kind": "height", "density": 0.002, "falloff": 0.05, "base": 20.0}],
              {-1})


def to_srgb(c):
    c = np.clip(c, 0, 1)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055) * 255


def srgb_to_linear_array(img):
    """8-bit sRGB pixels to linear light (IEC 61966-2-1), float64."""
    c = np.asarray(img, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def calibration_still(**fog):
    base = dict(scene="calibration", width=W, height=H,
                camera={"position": (0.0, 6.0, 0.0), "yaw": 0.0, "pitch": -6.0, "fov": 60.0},
                effects={"scatter": 0.0, "sky_distance": 400.0}, fog_color="#c0c8d0")
    base.update(fog)
    return StillParams.model_validate(base)


def check_pixels(renderer, still, min_share=0.8, render=None):
    """Every interior pixel of `still` against the blend of its object's colour and the fog
    colour by the float64 reference T; returns the objects seen. `render(still)` draws it
    (by default as a still: renderer.render)."""
    img = (render or renderer.render)(still).astype(np.float64)
    view = cam.view(still.camera, W, H)
    py, px = np.mgrid[0:H, 0:W]
    gl_y = H - 1 - py                                  # image rows are top first
    w = hand_rays(still.camera, px.ravel(), gl_y.ravel(), W, H)   # not the renderer's camera
    d, obj = cast(view.eye, w)
    obj = np.where(d < cam.FAR, obj, -1).reshape(H, W)   # beyond the far plane: sky
    # interior pixels only: the 3x3 neighbourhood sees the same object (MSAA edges excluded)
    same = np.ones((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= np.roll(np.roll(obj, dy, 0), dx, 1) == obj
    same[[0, -1], :] = False
    same[:, [0, -1]] = False
    sel = same.ravel()
    d = np.where(obj.ravel() == -1, still.effects.sky_distance, d)[sel]
    T = reference(still.fog(), np.broadcast_to(view.eye, (sel.sum(), 3)), w[sel], d, still.time)
    # the sky shows sky_affect of its fog (Godot's sky affect)
    T = np.where(obj.ravel()[sel] == -1, 1 - still.effects.sky_affect * (1 - T), T)
    albedo = {-1: scenes.CALIBRATION_SKY, 0: scenes.CALIBRATION_GROUND}
    albedo.update({i: c for i, (_, _, c) in enumerate(scenes.CALIBRATION_BOXES, start=1)})
    scene_lin = np.array([srgb_to_linear(albedo[o]) for o in obj.ravel()[sel]])
    fog_lin = np.array(srgb_to_linear(still.fog_color))
    want = to_srgb(T[:, None] * scene_lin + (1 - T[:, None]) * fog_lin)
    got = img.reshape(-1, 3)[sel]
    err = np.abs(got - want)
    assert sel.sum() > min_share * W * H
    assert err.max() <= 2.0, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert np.ptp(T) > 0.05           # the fog varies across the picture: the check has teeth
    return set(np.unique(obj[same]).tolist())
