"""A preview's scene pass reprojected when the camera only turned (issue 32: the picture
while the page drags). Left-drag turns the camera about its eye (static/camera.js), and a
turn about the eye maps the image of the scene onto itself exactly, whatever each pixel's
depth: a pixel of the new view sees along its ray, and the earlier view saw along that same
ray from the same eye (a homography, K R K^-1). Every G-buffer channel the scene pass
writes depends on the surface and the direction of its ray alone (its colour, its sky haze,
its distance from the eye, its direct sunlight; the sky's colour on the direction only), so
the earlier pass, resampled along the new rays (the nearest texel), is the new pass but
for resampling, and only the new view's part that the earlier one did not see is drawn
again (passes/warp.frag masks the rest by depth; passes/scene.py culls the meshes to the
rectangles round that part). On llvmpipe the scene pass of the default look's preview at
640x360 took 36 ms, about 10 of them vertices and the rest fragments; warped, while the
drag turns 2 degrees a frame, about 16 (6 the warp itself).

The earlier pass (the base, render/targets.py GBuffer.warp_base) is a preview's scene pass
drawn whole, at the new preview's size or larger (a smaller one, blown up, would stay
coarse: its terrain detail is chosen for its own size), and stays the base while later
previews warp from it: always from a drawn pass, never from a warped one, so resampling
errors do not add up over a drag (each warped pixel is within half a texel of where it
belongs). When the part not seen grows past WARP_MAX_SHARE of the frame, the pass is drawn
whole again and becomes the base.

A preview of the same look (its parameters all but the heading, the pitch, the time and
the size: look_key) warps the last such preview's finished frame instead
(passes/warp_out.frag), the look held at that frame's time for at most OUT_MAX_AGE_S; the
part it did not see is drawn and composited anew at that time. That frame's own scene pass
may have been warped: its pixels are then resampled twice, each time by the nearest texel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A warp whose rectangles to draw anew take more than this share of the frame draws the
# whole pass instead (and makes it the base): the warp then saves too little, and the base
# is refreshed while the drag goes on. At 640x360 turning 1.5 degrees a frame, the scene
# pass's median was 15.7 ms at 0.15, 15.9 at 0.25, 18.5 at 0.6.
WARP_MAX_SHARE = 0.4
# The pixel grid on which the part not seen is found (every pixel of the frame's border,
# and inside every STRIDE-th pixel), and how far each rectangle reaches past it (px): the
# part not seen touches the border (it is the frame less a convex region, the earlier
# frustum's image), and between two samples it can hide at most STRIDE px. The rectangles
# only cull: the warp's depth mask decides each pixel (passes/warp.frag).
STRIDE = 4
# The rectangles take rays this close to the base's edge (in its normalised device
# coordinates) as unseen: float32 in the shader against float64 here.
SEEN_EPS = 1e-5


@dataclass(frozen=True)
class Warp:
    """A warped scene pass: the base's view (scene/camera.py View) and framebuffer, and the rectangles of
    the new frame that hold what is drawn anew (x, y, width, height in px, y from the
    bottom), each with the view-projection that culls the meshes to it (none: the base
    saw it all)."""
    base: object
    source: object   # the base's framebuffer: colour, 1/distance (and sunlight), any size
    rects: tuple[tuple[tuple[int, int, int, int], np.ndarray], ...]


def warp_key(still, coarse_shadow: bool) -> tuple:
    """What a preview's scene pass depends on besides the camera's heading and pitch (and
    its size, its G-buffer's): a base and a preview with the same key warp (Renderer.begin).
    `coarse_shadow`: lit by the preview shadow map (render/passes/shadow.py)."""
    return (still.scene, still.camera.position, still.camera.fov, still.sun, coarse_shadow)


# A preview's finished frame is warped from one drawn at most this many seconds of the
# look's time before (passes/warp_out.frag): what moves in it (the wind's fog, the smoke)
# holds still in the part warped, for a drag's few frames, and the frame is drawn whole
# again past this.
OUT_MAX_AGE_S = 0.5


def look_key(still, coarse_shadow: bool) -> str:
    """What a preview's finished frame depends on besides the camera's heading and pitch,
    the time and its size: one with the same key warps to another."""
    cam = still.camera.model_copy(update={"yaw": 0.0, "pitch": 0.0})
    return (still.model_copy(update={"camera": cam, "time": 0.0, "width": 1, "height": 1}).model_dump_json()
            + str(coarse_shadow))


def base_ndc(base, view, px: np.ndarray, py: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the rays of `view`'s pixel centres (px, py; py from the bottom) cross the base
    view's image: its normalised device x and y, and whether the ray points in front of
    it. A View's right and up are scaled by tan(fov/2) (times the aspect), so a ray
    w = fwd + x right + y up has x = (w . right) / |right|^2 / (w . fwd)."""
    w = view.ray(px, py, width, height)
    z = w @ base.fwd
    front = z > 1e-6   # 1e-6: a ray at right angles to the base's axis is not in its image
    zs = np.where(front, z, 1.0)
    x = (w @ base.right) / (base.right @ base.right) / zs
    y = (w @ base.up) / (base.up @ base.up) / zs
    return x, y, front


def _bbox(px: np.ndarray, py: np.ndarray, mask: np.ndarray, width: int, height: int):
    """The rectangle (x, y, w, h px) round the masked samples, STRIDE px wider each way."""
    if not mask.any():
        return None
    x0, x1 = max(0, int(px[mask].min()) - STRIDE), min(width, int(px[mask].max()) + STRIDE + 1)
    y0, y1 = max(0, int(py[mask].min()) - STRIDE), min(height, int(py[mask].max()) + STRIDE + 1)
    return x0, y0, x1 - x0, y1 - y0


def unseen_rects(base, view, width: int, height: int) -> list[tuple[int, int, int, int]]:
    """Rectangles (x, y, w, h px, y from the bottom) that hold every pixel of `view` whose
    ray the base view did not see: one round those past each of its four edges (a ray
    within SEEN_EPS of an edge counts as past it: the shader decides each pixel in
    float32, passes/warp_seen.glsl, and a pixel it calls unseen must lie in a rectangle).
    A heading turned with the camera pitched is no turn about the image's vertical: the
    base's top and bottom edges tilt in the new image, each the other way, and leave a
    wedge a few px high along part of the frame's width beside the strip at its side (one
    bounding box round them all would be most of the frame; where two overlap, both draw
    it). All of the frame when a ray is behind the base; empty when it saw them all."""
    xs = np.unique(np.r_[np.arange(0, width, STRIDE), width - 1])
    ys = np.unique(np.r_[np.arange(0, height, STRIDE), height - 1])
    gx, gy = np.meshgrid(xs, ys)
    border_x = np.r_[np.arange(width), np.arange(width), np.zeros(height), np.full(height, width - 1)]
    border_y = np.r_[np.zeros(width), np.full(width, height - 1), np.arange(height), np.arange(height)]
    px = np.r_[gx.ravel(), border_x]
    py = np.r_[gy.ravel(), border_y]
    x, y, front = base_ndc(base, view, px.astype(float), py.astype(float), width, height)
    if not front.all():   # a turn past the base's side: nothing worth warping
        return [(0, 0, width, height)]
    edge = 1.0 - SEEN_EPS   # past its edges: a ray inside takes its nearest texel
    masks = (x < -edge, x > edge, y < -edge, y > edge)
    rects = [r for r in (_bbox(px, py, m, width, height) for m in masks) if r is not None]
    return rects


def crop(view_proj: np.ndarray, rect: tuple[int, int, int, int], width: int, height: int) -> np.ndarray:
    """The view-projection whose clip volume is the part of `view_proj`'s inside `rect`
    (px, y from the bottom): the rectangle's NDC range scaled to [-1, 1] (for culling)."""
    x, y, w, h = rect
    x0, x1 = 2.0 * x / width - 1.0, 2.0 * (x + w) / width - 1.0
    y0, y1 = 2.0 * y / height - 1.0, 2.0 * (y + h) / height - 1.0
    c = np.eye(4)
    c[0, 0], c[0, 3] = 2.0 / (x1 - x0), -(x1 + x0) / (x1 - x0)
    c[1, 1], c[1, 3] = 2.0 / (y1 - y0), -(y1 + y0) / (y1 - y0)
    return c @ np.asarray(view_proj, dtype=np.float64)


def plan(base_view, view, width: int, height: int, source=None) -> Warp | None:
    """The warp of a base drawn from `base_view` to `view` (the same eye and field of
    view), or None when too much of the new frame is unseen (WARP_MAX_SHARE)."""
    rects = unseen_rects(base_view, view, width, height)
    if sum(w * h for _, _, w, h in rects) > WARP_MAX_SHARE * width * height:
        return None
    return Warp(base_view, source, tuple((r, crop(view.view_proj, r, width, height)) for r in rects))
