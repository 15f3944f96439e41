"""Hand-written geometry for the GL tests: the camera's rays from its documented
convention (scipy's rotations, not scene/camera.py) and an analytic ray cast of the
calibration scene in float64."""

from __future__ import annotations

import numpy as np

from fogbank.scene import meshes as scenes


def hand_rotation(camera):
    """The camera's orientation from its documented convention, written with scipy's
    rotations and not with scene/camera.py: yaw 0 looks along -z and a positive yaw
    turns right (toward +x), a rotation of -yaw about +y; then a positive pitch looks up,
    +pitch about the camera's own x."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_euler("YX", [-camera.yaw, camera.pitch], degrees=True)


def hand_rays(camera, px, py, width, height):
    """Unit world rays through pixel centres (py from the bottom): camera space x right,
    y up, -z forward, the vertical field of view `fov`."""
    tan = np.tan(np.radians(camera.fov) / 2)
    nx = (np.asarray(px) + 0.5) / width * 2 - 1
    ny = (np.asarray(py) + 0.5) / height * 2 - 1
    v = np.stack([nx * tan * width / height, ny * tan, -np.ones_like(nx, dtype=float)], axis=-1)
    w = hand_rotation(camera).apply(v.reshape(-1, 3))
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def cast(eye, w):
    """Nearest hit of rays w from eye with the calibration scene: (distance, object index);
    index -1 is the sky, 0 the ground, 1.. the boxes."""
    n = len(w)
    best = np.full(n, np.inf)
    obj = np.full(n, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -eye[1] / w[:, 1]
    hit = (t > 0) & (np.abs(eye[0] + t * w[:, 0]) < 2000) & (np.abs(eye[2] + t * w[:, 2]) < 2000)
    best = np.where(hit, t, best)
    obj = np.where(hit, 0, obj)
    for i, (lo, hi, _) in enumerate(scenes.CALIBRATION_BOXES, start=1):
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = (np.array(lo) - eye) / w
            t1 = (np.array(hi) - eye) / w
        tmin = np.nanmax(np.minimum(t0, t1), axis=1)
        tmax = np.nanmin(np.maximum(t0, t1), axis=1)
        h = (tmax >= tmin) & (tmin > 0) & (tmin < best)
        best = np.where(h, tmin, best)
        obj = np.where(h, i, obj)
    return best, obj
