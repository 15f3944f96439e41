"""The camera's frustum test (scene/camera.py) against a hand-written projection of the
terrain chunks' own vertices."""

from __future__ import annotations

import numpy as np

from fogbank.model.params import Camera
from fogbank.scene import camera as cam
from fogbank.scene import meshes

CAMERAS = [Camera(position=(-35.0, 36.0, 85.0), yaw=30.0, pitch=-11.0, fov=60.0),   # the default look's
           Camera(position=(0.0, 300.0, 0.0), yaw=0.0, pitch=-89.0, fov=30.0),      # straight down, high
           Camera(position=(200.0, 3.0, -200.0), yaw=-135.0, pitch=5.0, fov=100.0),  # low, at a corner
           Camera(position=(0.0, 10.0, 600.0), yaw=180.0, pitch=0.0, fov=10.0)]      # outside, narrow


def _clip(view_proj: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Clip coordinates (x, y, z, w) of world points: the view-projection written out."""
    p = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    return p @ np.asarray(view_proj).T


def test_a_culled_chunk_is_wholly_outside_one_side_of_the_clip_volume_and_no_seen_chunk_is_culled():
    """For each camera and aspect: every chunk the frustum test drops has all its vertices
    beyond one and the same clip plane (x < -w, x > w, y < -w, ... z > w), so none of its
    triangles can reach the picture; every chunk with a vertex inside the clip volume is
    kept; and the test does drop chunks (the default view sees about half)."""
    m = meshes.build("countryside")
    verts = m.terrain_vertices[:, :3].astype(np.float64)
    culled_any = 0
    for c in CAMERAS:
        for w, h in ((1280, 720), (360, 640)):
            vp = cam.view(c, w, h).view_proj
            keep = cam.spheres_in_view(vp, m.terrain_chunks[:, 2:5], m.terrain_chunks[:, 5])
            for (first, count, *_), kept in zip(m.terrain_chunks, keep):
                idx = np.unique(m.terrain_indices[int(first):int(first + count)])
                x, y, z, ww = _clip(vp, verts[idx]).T
                inside = (np.abs(x) <= ww) & (np.abs(y) <= ww) & (np.abs(z) <= ww)
                if inside.any():
                    assert kept == True   # noqa: E712 (numpy bool)
                if not kept:
                    beyond = [x < -ww, x > ww, y < -ww, y > ww, z < -ww, z > ww]
                    assert any(bool(b.all()) for b in beyond) == True   # noqa: E712
                    culled_any += 1
    assert culled_any > 0


def test_the_planes_of_a_hand_made_frustum():
    """A camera at the origin looking down -z with a 90 degree square frustum: a point on
    the axis between near and far is inside every plane; one behind the eye is outside the
    near plane; one 45 degrees and more to the side is outside a side plane."""
    c = Camera(position=(0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, fov=90.0)
    vp = cam.view(c, 100, 100).view_proj
    planes = cam.frustum_planes(vp)
    side = lambda p: planes[:, :3] @ np.asarray(p, float) + planes[:, 3]  # noqa: E731
    assert bool((side([0, 0, -10]) > 0).all()) == True   # noqa: E712
    assert side([0, 0, 10])[4] < 0          # near
    assert side([0, 0, -cam.FAR - 1000.0])[5] < 0   # beyond the far plane
    assert side([11, 0, -10])[1] < 0        # right of x = -z
    assert side([0, -11, -10])[2] < 0       # below y = z
    radius = 1.0
    far_left = np.array([[-12.0, 0.0, -10.0]])   # 2 m beyond the left plane in x: 1.41 m away
    assert list(cam.spheres_in_view(vp, far_left, np.array([radius]))) == [False]
    assert list(cam.spheres_in_view(vp, far_left, np.array([1.5]))) == [True]
