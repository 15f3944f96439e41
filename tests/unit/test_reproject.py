"""render/reproject.py: where a turned view's rays cross the base view's image, and which
part of the new frame the base did not see, against a hand-written projection (world
points through each view's view-projection matrix, scene/camera.py)."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.model.params import Camera
from fogbank.render import reproject
from fogbank.scene import camera as cam

W, H = 320, 180


def _view(yaw: float, pitch: float, fov: float = 55.0):
    return cam.view(Camera(position=(-60.0, 22.0, 95.0), yaw=yaw, pitch=pitch, fov=fov), W, H)


def _pixel_of(view, point: np.ndarray) -> np.ndarray:
    """A world point's pixel (x, y from the bottom, centres at .5 - .5 = whole numbers)."""
    c = view.view_proj @ np.r_[point, 1.0]
    return (c[:2] / c[3] * 0.5 + 0.5) * [W, H] - 0.5


def _unseen_by_hand(base, view) -> np.ndarray:
    """(H, W) True where the base view did not see the pixel's ray: a point 100 m along
    it, projected by the base's view-projection, outside its image."""
    py, px = np.mgrid[0:H, 0:W].astype(float)
    nx, ny = (px + 0.5) / W * 2 - 1, (py + 0.5) / H * 2 - 1
    d = view.fwd + nx[..., None] * view.right + ny[..., None] * view.up
    p = view.eye + 100.0 * d / np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.concatenate([p, np.ones((H, W, 1))], axis=-1) @ base.view_proj.T
    ndc = c[..., :2] / c[..., 3:]
    return (c[..., 3] <= 0) | np.any(np.abs(ndc) > 1.0, axis=-1)


@pytest.mark.parametrize("turn", [(3.0, 0.0), (-6.0, -3.0), (0.0, 4.0), (10.0, 2.0)])
def test_a_turned_rays_crossing_is_the_projection_of_what_it_sees(turn):
    base, view = _view(-35.0, -8.0), _view(-35.0 + turn[0], -8.0 + turn[1])
    point = np.array([-20.0, 15.0, 40.0])
    at = _pixel_of(view, point)
    x, y, front = reproject.base_ndc(base, view, np.array([at[0]]), np.array([at[1]]), W, H)
    assert bool(front[0]) is True
    got = (np.r_[x, y] * 0.5 + 0.5) * [W, H] - 0.5
    np.testing.assert_allclose(got, _pixel_of(base, point), atol=1e-6)


@pytest.mark.parametrize("turn", [(2.0, 0.0), (-6.0, -3.0), (0.0, 4.0), (8.0, 2.5), (-1.0, 0.3)])
def test_every_pixel_the_base_did_not_see_is_drawn_anew(turn):
    base, view = _view(-35.0, -8.0), _view(-35.0 + turn[0], -8.0 + turn[1])
    unseen = _unseen_by_hand(base, view)
    covered = np.zeros((H, W), bool)
    for x, y, w, h in reproject.unseen_rects(base, view, W, H):
        covered[y:y + h, x:x + w] = True
    assert int((unseen & ~covered).sum()) == 0
    assert unseen.sum() > 0
    # and the rectangles are no blanket: at most the unseen pixels' bounding strips and
    # their STRIDE margins
    assert covered.sum() <= 2 * unseen.sum() + 4 * reproject.STRIDE * (W + H) * 2


def test_a_view_turned_back_to_its_base_is_all_seen():
    assert reproject.unseen_rects(_view(-35.0, -8.0), _view(-35.0, -8.0), W, H) == []


def test_a_wide_turn_draws_the_whole_pass():
    assert reproject.plan(_view(-35.0, -8.0), _view(5.0, -8.0), W, H) is None
    assert reproject.plan(_view(-35.0, -8.0), _view(-33.0, -8.0), W, H) is not None


def test_the_crop_keeps_what_projects_into_its_rectangle():
    view = _view(-35.0, -8.0)
    rect = (250, 0, 70, 180)
    m = reproject.crop(view.view_proj, rect, W, H)
    for point in (np.array([-20.0, 15.0, 40.0]), np.array([-90.0, 10.0, 30.0]), np.array([40.0, 5.0, 20.0])):
        px, py = _pixel_of(view, point)
        inside = 250 <= px + 0.5 <= 320 and 0 <= py + 0.5 <= 180
        c = m @ np.r_[point, 1.0]
        assert bool(np.all(np.abs(c[:2]) <= c[3])) == inside
