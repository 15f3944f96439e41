"""The terrain's lightmap (passes/shadow.py, passes/lightmap.frag) and its use by the scene
pass, against a float64 numpy percentage-closer filter of the read-back shadow map at the
terrain's own surface points (scene/terrain.py)."""

from __future__ import annotations

import numpy as np

from fogbank.model import presets as P
from fogbank.model.fields import srgb_to_linear
from fogbank.model.params import StillParams
from fogbank.render.passes.shadow import sun_key
from fogbank.render.resources import SHADOW_SIZE
from fogbank.scene import terrain

LIGHTMAP_SIZE = SHADOW_SIZE   # the full map's lightmap has its texels

LOW_SUN = {"azimuth": 120.0, "elevation": 12.0, "color": "#ffffff", "intensity": 2.0}


def _look(**update) -> StillParams:
    d = P.preset_dict("default")
    return StillParams.model_validate({**d, "sun": LOW_SUN, "density": 0.0, "width": 320, "height": 180,
                                       "camera": {"position": (10.0, 25.0, 60.0), "yaw": 20.0, "pitch": -25.0,
                                                  "fov": 60.0}, **update})


def _pcf(depth: np.ndarray, sun_view_proj: np.ndarray, sun_dir: np.ndarray, pts: np.ndarray,
         normals: np.ndarray) -> np.ndarray:
    """sunVisibility in float64: four bilinear 2x2 comparisons (ref <= stored: lit) half a
    texel apart, with the slope-scaled bias; 1 outside the map."""
    n = depth.shape[0]
    clip = np.concatenate([pts, np.ones((len(pts), 1))], axis=1) @ sun_view_proj.T
    p = clip[:, :3] / clip[:, 3:4] * 0.5 + 0.5
    bias = 0.0006 + 0.0025 * (1.0 - np.clip(normals @ sun_dir, 0.0, 1.0))
    ref = p[:, 2] - bias
    vis = np.zeros(len(pts))
    for i in range(4):
        o = (np.array([i & 1, i >> 1]) - 0.5) / n
        uv = p[:, :2] + o
        f = uv * n - 0.5
        i0 = np.floor(f).astype(int)
        t = f - i0
        acc = np.zeros(len(pts))
        for dy in (0, 1):
            for dx in (0, 1):
                x = np.clip(i0[:, 0] + dx, 0, n - 1)   # clamp to edge, as the texture
                y = np.clip(i0[:, 1] + dy, 0, n - 1)
                w = (t[:, 0] if dx else 1 - t[:, 0]) * (t[:, 1] if dy else 1 - t[:, 1])
                acc += w * (ref <= depth[y, x])
        vis += acc
    vis /= 4
    outside = np.any((p < 0) | (p > 1), axis=1)
    return np.where(outside, 1.0, vis)


def _mesh_height(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The detailed terrain mesh's own height at (x, z): the plane of the grid triangle over
    it (scene/meshes.py: cells split a-c-b, b-c-d, the diagonal from b to c)."""
    from fogbank.scene import meshes
    n = meshes.TERRAIN_CELLS
    E = terrain.EXTENT
    xs = np.linspace(-E, E, n)
    Y = terrain.height(*np.meshgrid(xs, xs, indexing="xy"))
    fx, fz = (x + E) / (2 * E) * (n - 1), (z + E) / (2 * E) * (n - 1)
    i, j = np.clip(np.floor(fx).astype(int), 0, n - 2), np.clip(np.floor(fz).astype(int), 0, n - 2)
    u, v = fx - i, fz - j
    a, b, c, d = Y[j, i], Y[j, i + 1], Y[j + 1, i], Y[j + 1, i + 1]
    lower = u + v <= 1   # triangle a, b, c; else b, c, d
    return np.where(lower, a + (b - a) * u + (c - a) * v, d + (c - d) * (1 - u) + (b - d) * (1 - v))


def _maps(renderer, still):
    r = renderer
    r.shadows.clear()   # draw the map and bake the lightmap for this sun
    r.render(still, slot="test-shadow", msaa=False)
    sm = r.shadows.get(sun_key(still))
    depth = np.frombuffer(sm.tex.read(), np.float32).reshape(SHADOW_SIZE, SHADOW_SIZE).astype(np.float64)
    lm = np.frombuffer(sm.lightmap.read(), np.uint8).reshape(LIGHTMAP_SIZE, LIGHTMAP_SIZE) / 255.0
    from fogbank.scene import camera as cam
    center, half = r.meshes.get(still.scene).bounds
    svp = cam.ortho_sun(still.sun.direction(), center, half)
    return depth, lm, svp, sm.lightmap_rect


def test_the_lightmap_is_the_sun_visibility_of_the_terrain_under_each_texel(renderer):
    still = _look()
    depth, lm, svp, rect = _maps(renderer, still)
    rng = np.random.default_rng(5)
    ij = rng.integers(0, LIGHTMAP_SIZE, (20000, 2))
    x = rect[0] + (ij[:, 0] + 0.5) / rect[2] / LIGHTMAP_SIZE
    z = rect[1] + (ij[:, 1] + 0.5) / rect[3] / LIGHTMAP_SIZE
    grid = (np.abs(x) < terrain.EXTENT) & (np.abs(z) < terrain.EXTENT)   # the detailed mesh's texels
    ij, x, z = ij[grid], x[grid], z[grid]
    pts = np.stack([x, _mesh_height(x, z), z], axis=1)
    ref = _pcf(depth, svp, still.sun.direction(), pts, terrain.normal(x, z))
    got = lm[ij[:, 1], ij[:, 0]]
    diff = np.abs(got - ref)
    # at the mesh's own surface point the bake is the filter itself, to 8 bits (1.4e-4 here)
    assert float(np.mean(diff)) < 1e-3
    assert float(np.max(diff)) < 0.1
    assert 0.05 < float(np.mean(ref < 0.5)) < 0.95     # a low sun: shadowed and lit ground both


def test_the_scene_pass_lights_each_terrain_pixel_by_the_lightmap_at_its_place(renderer):
    """From the G-buffer: the direct sunlight over the ambient light of a terrain pixel is
    sun colour 0.55 max(n.L, 0) visibility / ambient(n), the albedo cancelling; the
    visibility recovered from it matches the float64 filter at the pixel's surface point."""
    still = _look()
    depth, _, svp, _ = _maps(renderer, still)
    g = renderer.caches.gbuffer("test-shadow", still.width, still.height, True)
    w, h = still.width, still.height
    color = np.frombuffer(g.color.read(), np.float16).reshape(h, w, 4)[..., :3].astype(np.float64)
    sun = np.frombuffer(g.sunlight.read(), np.float16).reshape(h, w, 4)[..., :3].astype(np.float64)
    invd = np.frombuffer(g.invdist.read(), np.float32).reshape(h, w).astype(np.float64)
    from fogbank.scene import camera as cam
    view = cam.view(still.camera, w, h)
    py, px = np.mgrid[0:h, 0:w]
    dirs = view.ray(px.ravel(), py.ravel(), w, h)
    d = np.where(invd.ravel() > 0, 1.0 / np.maximum(invd.ravel(), 1e-30), 0.0)
    pts = view.eye + dirs * d[:, None]
    ground = terrain.height(pts[:, 0], pts[:, 2])
    # terrain pixels: on the height field (not a tree, house or the water), lit by some sun
    n = terrain.normal(pts[:, 0], pts[:, 2])
    L = still.sun.direction()
    ndl = n @ L
    on = (d > 0) & (np.abs(pts[:, 1] - ground) < 0.05) & (ndl > 0.2) & (pts[:, 1] > 0.3)
    assert int(on.sum()) > 5000
    sky, grd = np.array([0.30, 0.36, 0.46]), np.array([0.16, 0.15, 0.12])
    ambient = grd + (sky - grd) * (n[:, 1:2] * 0.5 + 0.5)
    sun_color = np.array(srgb_to_linear(still.sun.color)) * still.sun.intensity
    c, s = color.reshape(-1, 3)[on], sun.reshape(-1, 3)[on]
    # the air's haze between (common/sky.glsl atmosphereHaze), taken off: the surface keeps
    # exp(-d / 3000 m) of its light, and the rest is the horizon sky's colour with the sun's
    # glow in the pixel's horizontal direction
    air = np.exp(-d[on] / 3000.0)[:, None]
    hor = dirs[on] * [1.0, 0.0, 1.0]
    hor /= np.linalg.norm(hor, axis=1, keepdims=True)
    cos_sun = np.maximum(hor @ L, 0.0)[:, None]
    haze = np.array([0.62, 0.70, 0.80]) + sun_color * (0.05 * cos_sun ** 8 + 0.25 * cos_sun ** 180)
    c, s = (c - (1.0 - air) * haze) / air, s / air
    vis = (s[:, 1] / (c[:, 1] - s[:, 1])) * ambient[on, 1] / (sun_color[1] * 0.55 * ndl[on])
    ref = _pcf(depth, svp, L, pts[on], n[on])
    diff = np.abs(vis - ref)
    # the lightmap is read bilinearly between texels 0.23 m apart: only along a shadow's edge
    # does that differ from the filter at the pixel's own point (1.3% of pixels here)
    assert float(np.median(diff)) < 0.02
    assert float(np.mean(diff > 0.3)) < 0.03


def test_a_previews_map_is_drawn_for_a_sun_the_full_map_is_not_and_shows_its_shadows(renderer):
    """A preview (draft) whose sun the full map was not drawn for is lit by the preview map
    (render/resources.py DRAFT_SHADOW_SIZE, terrain at DRAFT_SHADOW_LEVEL): the full map is
    left as it was, and the preview map's lightmap is the full map's, coarser: averaged
    over the 4x4 full texels under each of its texels the two agree but at shadow edges,
    with as much ground in shadow, and neither is lighter on average. The preview picture against the full-quality one (no
    fog): within a few levels but along shadow edges."""
    from fogbank.render.resources import DRAFT_SHADOW_SIZE
    still = _look()
    full_depth, full_lm, _, _ = _maps(renderer, still)
    full_img = renderer.render(still, slot="test-shadow", msaa=False)
    renderer.shadows.clear()   # no full map is this sun's now: a preview takes the preview map
    drawn = renderer.shadows.drawn
    img = renderer.render(still, slot="test-shadow-draft", msaa=False, draft=True)
    assert (renderer.shadows.drawn, renderer.shadows.get(sun_key(still))) == (drawn, None)
    sm = renderer.shadows.draft
    assert sm.key == (still.scene, still.sun.azimuth, still.sun.elevation)
    n = DRAFT_SHADOW_SIZE
    lm = np.frombuffer(sm.lightmap.read(), np.uint8).reshape(n, n) / 255.0
    k = LIGHTMAP_SIZE // n
    coarse = full_lm.reshape(n, k, n, k).mean(axis=(1, 3))
    diff = np.abs(lm - coarse)
    # 0.042 here; its depth bias at the full map's, acne stripes the ground: 0.154
    assert float(np.mean(diff)) < 0.06
    assert float(np.mean(diff > 0.25)) < 0.08
    assert abs(float(np.mean(lm - coarse))) < 0.03
    assert abs(float(np.mean(lm < 0.5)) - float(np.mean(coarse < 0.5))) < 0.03
    px = np.abs(img.astype(int) - full_img.astype(int)).max(axis=2)
    assert float(px.mean()) < 1.0
    assert float(np.percentile(px, 99)) <= 12


def test_a_full_frame_never_reuses_a_scene_pass_lit_by_the_previews_map(renderer):
    """A preview's scene pass (lit by the preview map here) is held for the next previews,
    never for a full frame at its size, with MSAA or without: that frame's pixels are those
    of a slot that never drew a preview. A preview after the full map is drawn for its sun
    is lit by it: the full frame's pixels."""
    still = _look(sun={**LOW_SUN, "azimuth": 75.0})
    for msaa, slot in ((False, "test-draft-a"), (True, "test-draft-m")):
        g = renderer.caches.gbuffer(slot, still.width, still.height, True)
        renderer.shadows.clear()
        first = renderer.render(still, slot=slot, msaa=False, draft=True)
        renderer.render(still.model_copy(update={"time": still.time + 1.0}), slot=slot, msaa=False, draft=True)
        assert g.scene_key[4] is True
        full = renderer.render(still, slot=slot, msaa=msaa)
        fresh = renderer.render(still, slot=slot + "-fresh", msaa=msaa)
        assert np.array_equal(full, fresh) is True
        if not msaa:
            assert np.array_equal(first, fresh) is False   # the same frame, lit by the preview map
    preview = renderer.render(still, slot="test-draft-c", msaa=False, draft=True)
    assert np.array_equal(preview, renderer.render(still, slot="test-draft-a-fresh", msaa=False)) is True


def test_the_worker_keeps_a_full_map_for_each_of_a_few_suns(renderer):
    """Streams with light shafts sample the full shadow map at every frame. Sessions whose
    suns differ each find theirs kept (resources.SHADOW_MAPS, least recently used let go):
    frames in turn draw each map once, and show what they showed when it was drawn; a
    sun past the kept ones takes the least recently used one's place, which is drawn
    again when its sun returns."""
    from fogbank.render.resources import SHADOW_MAPS
    base = _look(effects={**P.preset_dict("default")["effects"], "shafts": 1.0}, density=0.5,
                 width=160, height=90)
    suns = [base.model_copy(update={"sun": base.sun.model_copy(update={"azimuth": 60.0 + 30.0 * i})})
            for i in range(SHADOW_MAPS + 1)]
    renderer.shadows.clear()
    drawn, new = renderer.shadows.drawn, renderer.shadows.new_suns
    first = [renderer.render(s, slot=f"test-suns-{i}", msaa=False) for i, s in enumerate(suns[:SHADOW_MAPS])]
    again = [renderer.render(s, slot=f"test-suns-{i}", msaa=False) for i, s in enumerate(suns[:SHADOW_MAPS])]
    assert renderer.shadows.drawn - drawn == SHADOW_MAPS
    assert [np.array_equal(a, b) for a, b in zip(first, again)] == [True] * SHADOW_MAPS
    assert np.array_equal(first[0], first[1]) is False   # the suns' shafts differ
    renderer.render(suns[-1], slot="test-suns-last", msaa=False)
    back = renderer.render(suns[0], slot="test-suns-0", msaa=False)
    assert renderer.shadows.drawn - drawn == SHADOW_MAPS + 2
    assert np.array_equal(back, first[0]) is True
    # a sun drawn lately and drawn again (maps evicting each other) is the looks' own cost,
    # not work done once for a new sun (workers/worker.py `once`)
    assert renderer.shadows.new_suns - new == SHADOW_MAPS + 1


def test_a_previews_light_shafts_sample_the_previews_map_as_the_full_one(renderer):
    """Light shafts sample the frame's shadow map along each view ray (passes/fog.frag,
    the depth bias scaled as the scene pass's): a preview lit by the preview map shows
    the full frame's shafts but for a level here and there, with the sun low or high."""
    for elevation in (12.0, 35.0):
        still = _look(effects={**P.preset_dict("default")["effects"], "shafts": 1.0}, density=0.8,
                      sun={**LOW_SUN, "elevation": elevation})
        full = renderer.render(still, slot="test-shafts-full", msaa=False)
        renderer.shadows.clear()
        draft = renderer.render(still, slot="test-shafts-draft", msaa=False, draft=True)
        assert renderer.shadows.draft.key == (still.scene, still.sun.azimuth, elevation)
        px = np.abs(full.astype(int) - draft.astype(int)).max(axis=2)
        assert float(px.mean()) < 0.5
        assert float(np.percentile(px, 99)) <= 2
