"""Camera basis, view and projection matrices, and the view ray through a pixel."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fogbank.model.params import Camera  # the type only: scene reads the model, never the reverse

NEAR = 0.25   # m
FAR = 150000.0  # m: the far land reaches 120 km (scene/meshes.py SKIRT_OUTER), past the horizon seen from the camera bounds (101 km from 800 m); a 24-bit depth resolves 0.24 m at 1 km whatever the far plane, set by the near one


@dataclass(frozen=True)
class View:
    eye: np.ndarray
    fwd: np.ndarray
    right: np.ndarray   # scaled by tan(fov/2) * aspect
    up: np.ndarray      # scaled by tan(fov/2)
    view_proj: np.ndarray

    def ray(self, px: np.ndarray, py: np.ndarray, width: int, height: int) -> np.ndarray:
        """Unit world directions through pixel centres (px, py), py counted from the bottom."""
        nx = (np.asarray(px) + 0.5) / width * 2 - 1
        ny = (np.asarray(py) + 0.5) / height * 2 - 1
        w = self.fwd + nx[..., None] * self.right + ny[..., None] * self.up
        return w / np.linalg.norm(w, axis=-1, keepdims=True)


def basis(cam: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward, right, up (unit). Yaw 0 looks along -z; positive yaw turns right (+x)."""
    y, p = math.radians(cam.yaw), math.radians(cam.pitch)
    fwd = np.array([math.sin(y) * math.cos(p), math.sin(p), -math.cos(y) * math.cos(p)])
    right = np.array([math.cos(y), 0.0, math.sin(y)])
    up = np.cross(right, fwd)
    return fwd, right, up


def look_at(eye, fwd, right, up) -> np.ndarray:
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = right, up, -fwd
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y_deg: float, aspect: float, near: float = NEAR, far: float = FAR) -> np.ndarray:
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def view(cam: Camera, width: int, height: int) -> View:
    aspect = width / height
    fwd, right, up = basis(cam)
    tan = math.tan(math.radians(cam.fov) / 2)
    eye = np.asarray(cam.position, dtype=np.float64)
    vp = perspective(cam.fov, aspect) @ look_at(eye, fwd, right, up)
    return View(eye, fwd, right * tan * aspect, up * tan, vp)


def frustum_planes(view_proj: np.ndarray) -> np.ndarray:
    """The six planes (a, b, c, d) of a view-projection's clip volume, inside where
    a x + b y + c z + d >= 0 (Gribb & Hartmann 2001): left, right, bottom, top, near, far."""
    m = np.asarray(view_proj, dtype=np.float64)
    return np.array([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]])


def spheres_in_view(view_proj: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Which spheres may be seen: False only for a sphere wholly outside one plane of the
    clip volume (so every point of what it bounds is clipped away)."""
    planes = frustum_planes(view_proj)
    norms = np.linalg.norm(planes[:, :3], axis=1)
    dist = (np.asarray(centres) @ planes[:, :3].T + planes[:, 3]) / norms   # m, signed, (K, 6)
    return np.all(dist >= -np.asarray(radii)[:, None], axis=1)


def ortho_sun(direction: np.ndarray, center: np.ndarray, half: float) -> np.ndarray:
    """View-projection of an orthographic camera looking along -direction (toward the
    ground from the sun), covering a cube of half-size `half` around `center`."""
    L = np.asarray(direction, dtype=np.float64)
    L = L / np.linalg.norm(L)
    fwd = -L
    helper = np.array([0.0, 1.0, 0.0]) if abs(fwd[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
    right = np.cross(fwd, helper)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    eye = center + L * half * 2
    m = np.zeros((4, 4))
    m[0, 0] = m[1, 1] = 1.0 / half
    m[2, 2] = -1.0 / (2 * half)
    m[2, 3] = -1.0
    m[3, 3] = 1.0
    # z maps [0, 4 half] in front of the eye to [-1, 1]
    return m @ look_at(eye, fwd, right, up)
