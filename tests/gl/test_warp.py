"""A preview's scene pass warped when the camera only turns (render/reproject.py,
passes/warp.frag): the warped G-buffer against a hand-written reprojection of the base's
(numpy: each pixel's ray through the base's view-projection, its nearest texel), and the
part the base did not see against the same view's scene pass drawn whole."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.model.params import StillParams
from fogbank.model.presets import preset_dict

W, H = 320, 180


def _look(yaw_turn: float, pitch_turn: float = 0.0, size: tuple[int, int] = (W, H), density: float = 1.0) -> StillParams:
    d = {**preset_dict("default"), "width": size[0], "height": size[1], "time": 1.0, "density": density}
    d["camera"] = {**d["camera"], "yaw": d["camera"]["yaw"] + yaw_turn, "pitch": d["camera"]["pitch"] + pitch_turn}
    d["effects"] = {**d["effects"], "fog_scale": 4}
    return StillParams.model_validate(d)


def _gbuffer(renderer, slot, size: tuple[int, int] = (W, H)):
    """(colour RGB, 1/distance, sunlight RGB) of the slot's G-buffer, bottom row first."""
    w, h = size
    g = renderer.caches.gbuffer(slot, w, h, True)
    color = np.frombuffer(g.color.read(), np.float16).reshape(h, w, 4)[..., :3].astype(np.float64)
    invd = np.frombuffer(g.invdist.read(), np.float32).reshape(h, w).astype(np.float64)
    sun = np.frombuffer(g.sunlight.read(), np.float16).reshape(h, w, 4)[..., :3].astype(np.float64)
    return color, invd, sun


def _by_hand(base_view, view, size: tuple[int, int] = (W, H), base_size: tuple[int, int] = (W, H)):
    """For each pixel of `view` (bottom row first): the base's texel its ray crosses, and
    whether the base saw it, from a point 100 m along the ray through the base's
    view-projection."""
    (W, H), (BW, BH) = size, base_size
    py, px = np.mgrid[0:H, 0:W].astype(np.float64)
    nx, ny = (px + 0.5) / W * 2 - 1, (py + 0.5) / H * 2 - 1
    d = view.fwd + nx[..., None] * view.right + ny[..., None] * view.up
    p = view.eye + 100.0 * d / np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.concatenate([p, np.ones((H, W, 1))], axis=-1) @ base_view.view_proj.T
    ndc = c[..., :2] / c[..., 3:]
    seen = (c[..., 3] > 0) & np.all(np.abs(ndc) <= 1.0, axis=-1)
    tx = np.clip(np.floor((ndc[..., 0] * 0.5 + 0.5) * BW), 0, BW - 1).astype(int)
    ty = np.clip(np.floor((ndc[..., 1] * 0.5 + 0.5) * BH), 0, BH - 1).astype(int)
    return tx, ty, seen


# (turn, the turned preview's size): the drag's ladder may change the size between (a
# base of another size serves)
@pytest.mark.parametrize("turn,size", [((2.0, 0.0), (W, H)), ((-5.0, -2.0), (W, H)), ((3.0, 1.0), (160, 90)),
                                       ((-2.0, 0.0), (224, 126))])
def test_a_turned_preview_is_its_base_along_the_new_rays(renderer, turn, size):
    from fogbank.scene import camera as cam
    # another density: the same scene pass, but not the same finished frame, which a preview
    # of the same look warps instead (test_a_turned_previews_frame_...)
    base, turned = _look(0.0), _look(*turn, size=size, density=1.1)
    slot = f"warp-test-{turn}"
    renderer.render(base, slot=slot, msaa=False, draft=True)
    assert renderer.scene_warped is False
    b_color, b_invd, b_sun = _gbuffer(renderer, slot)
    renderer.render(turned, slot=slot, msaa=False, draft=True)
    assert renderer.warped == "scene"
    color, invd, sun = _gbuffer(renderer, slot, size)
    tx, ty, seen = _by_hand(cam.view(base.camera, W, H), cam.view(turned.camera, *size), size)
    # the hand's ray and the shader's differ in float32 rounding: a pixel whose ray falls
    # within 1e-4 texel of a texel's edge may take the neighbour; none here may
    same = (np.abs(color - b_color[ty, tx]).max(axis=2) == 0) & (invd == b_invd[ty, tx]) \
        & (np.abs(sun - b_sun[ty, tx]).max(axis=2) == 0)
    assert seen.mean() > 0.7
    assert float(1.0 - same[seen].mean()) <= 0.002
    # what the base did not see is the scene pass itself: drawn whole in another slot
    renderer.render(turned, slot=f"{slot}-whole", msaa=False, draft=True)
    assert renderer.scene_warped is False
    w_color, w_invd, _ = _gbuffer(renderer, f"{slot}-whole", size)
    unseen = ~seen
    assert unseen.sum() > 100
    assert float(np.abs(invd[unseen] - w_invd[unseen]).max()) == 0.0
    assert float(np.abs(color[unseen] - w_color[unseen]).max()) == 0.0


def test_a_preview_that_moves_the_eye_or_turns_far_is_drawn_whole(renderer):
    renderer.render(_look(0.0), slot="warp-test-2", msaa=False, draft=True)
    renderer.render(_look(50.0), slot="warp-test-2", msaa=False, draft=True)
    assert renderer.scene_warped is False   # most of the view unseen: drawn whole, the new base
    moved = _look(50.0).model_copy(deep=True)
    moved.camera.position = (moved.camera.position[0] + 1.0, *moved.camera.position[1:])
    renderer.render(moved, slot="warp-test-2", msaa=False, draft=True)
    assert renderer.scene_warped is False
    renderer.render(_look(52.0), slot="warp-test-2", msaa=True, draft=False)   # a full frame never warps
    assert renderer.scene_warped is False


def test_a_turned_previews_frame_is_the_last_frame_along_the_new_rays(renderer):
    """A preview of the same look, the camera only turned (and the time on by less than
    OUT_MAX_AGE_S), warps the last preview's finished frame (passes/warp_out.frag), the
    look at that frame's time: where that frame saw the ray, its nearest pixel (a
    hand-written reprojection of the decoded frames); where it did not, the preview
    composited anew, as the same view drawn whole at that time."""
    from fogbank.render import reproject
    from fogbank.scene import camera as cam
    from fogbank.render.passes import FRAME_PASSES
    base, turned = _look(0.0), _look(-4.0, -2.0).model_copy(update={"time": 1.2})
    before = renderer.render(base, slot="warp-frame", msaa=False, draft=True)
    base_plan = renderer.caches.gbuffer("warp-frame", W, H, True).last_plan[1]
    f = renderer.begin(turned, "warp-frame", False, False, True)
    assert renderer.warped == "frame"
    # the look at its base's time, and the plan made for it (the same look, eye and time)
    assert f.still.time == base.time
    assert f.plan is base_plan
    f.channels = 3
    for p in FRAME_PASSES:
        p.run(renderer, f)
    renderer.keep_only(f)
    got = f.image.copy()
    whole = renderer.render(turned.model_copy(update={"time": base.time}), slot="warp-frame-whole", msaa=False,
                            draft=True)
    assert renderer.warped is None
    tx, ty, seen = _by_hand(cam.view(base.camera, W, H), cam.view(turned.camera, W, H))
    # images are top row first; the hand's arrays bottom row first
    got_b, whole_b, before_b = got[::-1].astype(int), whole[::-1].astype(int), before[::-1].astype(int)
    same = np.all(got_b == before_b[ty, tx], axis=2)
    assert 0.5 < seen.mean() < 0.99
    assert float(1.0 - same[seen].mean()) <= 0.002
    d = np.abs(got_b - whole_b).max(axis=2)[~seen]
    # the part composited anew: its fog texels next to the part warped see that part's
    # cleared scene pass (the sky), a few pixels off by more than a level
    assert float(np.mean(d <= 2)) >= 0.97
    assert float(d.mean()) <= 0.6
    # past OUT_MAX_AGE_S of the look's time, or with the look changed, the frame is drawn
    later = turned.model_copy(update={"time": 1.2 + 2 * reproject.OUT_MAX_AGE_S,
                                      "camera": _look(-5.0, -2.0).camera})
    renderer.render(later, slot="warp-frame", msaa=False, draft=True)
    assert renderer.warped == "scene"
    denser = _look(-6.0, -2.0, density=1.2).model_copy(update={"time": later.time})
    renderer.render(denser, slot="warp-frame", msaa=False, draft=True)
    assert renderer.warped == "scene"


def test_a_previews_frame_warps_from_the_last_one_as_large_or_larger(renderer):
    """The drag's ladder changes the previews' size: a preview at a smaller size warps the
    slot's last frame drawn whole at a larger one (its nearest pixel, the hand's
    reprojection); a larger one does not take a smaller base, which blown up would stay
    coarse, and draws whole."""
    from fogbank.scene import camera as cam
    base = _look(0.0, size=(448, 252))
    turned = _look(3.0, 1.0).model_copy(update={"time": 1.1})
    before = renderer.render(base, slot="warp-frame-size", msaa=False, draft=True)
    got = renderer.render(turned, slot="warp-frame-size", msaa=False, draft=True)
    assert renderer.warped == "frame"
    tx, ty, seen = _by_hand(cam.view(base.camera, 448, 252), cam.view(turned.camera, W, H), (W, H), (448, 252))
    same = np.all(got[::-1].astype(int) == before[::-1].astype(int)[ty, tx], axis=2)
    assert seen.mean() > 0.7
    assert float(1.0 - same[seen].mean()) <= 0.002
    larger = _look(4.0, 1.0, size=(640, 360)).model_copy(update={"time": 1.1})
    renderer.render(larger, slot="warp-frame-size", msaa=False, draft=True)
    assert renderer.warped is None


def test_a_full_frame_lets_the_bases_go_and_a_still_camera_is_not_warped(renderer):
    """A frame that does not turn is not warped (it would show the base's moment again),
    and a full frame ends the drag: its G-buffer lets its warp bases go."""
    base = _look(0.0)
    renderer.render(base, slot="warp-bases", msaa=False, draft=True)
    g = renderer.caches.gbuffer("warp-bases", W, H, True)
    assert g.warp_base is not None and g.out_base is not None
    renderer.render(base.model_copy(update={"time": 1.2, "density": 1.3}), slot="warp-bases", msaa=False,
                    draft=True)
    assert renderer.warped is None   # the same camera, its scene pass reused
    renderer.render(_look(2.0), slot="warp-bases", msaa=True, draft=False)
    assert g.warp_base is None and g.out_base is None
