"""The composite (render/passes/composite.py) of a stream whose camera stays still: the
held composite, from inputs drawn once over the still scene and the held fog, against the
calibration scene's float64 reference blend (tests/calibration.py), and against the full
composite of the same frame as a still, over the effects it reads."""

from __future__ import annotations

import numpy as np
import pytest

from calibration import FAR_CAMERA, calibration_still, check_pixels
from fogbank.model.params import StillParams
from fogbank.render.passes import FRAME_PASSES

WINDY = [{"kind": "height", "density": 0.05, "falloff": 0.2, "base": 0.0},
         {"kind": "cosine", "density": 0.01, "c0": 1.0, "scale": 10.0, "wind": True,
          "terms": [{"amp": 0.8, "k": (1.0, 2.0, 0.5), "phase": 0.3}]},
         {"kind": "particles", "count": 300, "emitter": (0.0, 1.0, -40.0), "spread": 70.0, "speed": 3.0,
          "radius": 5.0, "alpha": 0.5, "life_min": 30, "life_max": 60}]


def held_frame(renderer, slot: str, msaa: bool = True):
    """Draw a look as a stream does while time runs and the camera stays, in a new slot:
    three frames before, at earlier times (the third draws the held fog and the held
    composite's inputs), so that this one reuses both as they were drawn for another time
    (asserted; the fused blur keeps the full composite)."""
    def render(s: StillParams) -> np.ndarray:
        renderer.drop_slot(slot)
        for dt in (-1.5, -1.0, -0.5):
            renderer.render(s.model_copy(update={"time": s.time + dt}), slot, msaa, hold_fog=True)
        g = renderer.caches.gbuffer(slot, s.width, s.height, s.effects.sun_through_fog)
        h = g.held[s.effects.fog_scale]
        drawn = (h.key, h.inputs_key)
        f = renderer.begin(s, slot, msaa, hold_fog=True)
        for p in FRAME_PASSES:
            p.run(renderer, f)
        renderer.keep_only(f)
        assert f.held_fog is h and (h.key, h.inputs_key) == drawn   # reused, not drawn again
        assert (h.inputs_key is not None) == (s.effects.blur != "single")
        image = f.image
        renderer.drop_slot(slot)
        return image
    return render


@pytest.mark.parametrize("effects", [{}, {"density": 1.7, "max_opacity": 0.8, "start_distance": 12.0},
                                     {"cutoff_distance": 60.0, "cutoff_mode": "fog"}, {"sky_affect": 0.3}])
def test_a_held_frame_matches_the_reference_blend(renderer, effects):
    """At full fog resolution (a coarser fog's upsample is held to the full composite's in
    the next test: against this exact reference it errs by its interpolation alone)."""
    still = calibration_still(layers=WINDY, time=4.0, density=effects.get("density", 1.0))
    eff = {k: v for k, v in effects.items() if k != "density"}
    still = still.model_copy(update={"effects": still.effects.model_copy(update=eff)})
    objects = check_pixels(renderer, still, render=held_frame(renderer, "held-calibration"))
    assert objects == {-1, 0, 1, 2, 3, 4}


@pytest.mark.parametrize("effects", [
    {"phase": "henyey-greenstein", "anisotropy": 0.6, "scatter": 0.2, "shafts": 1.0, "sun_through_fog": True},
    {"phase": "gawron", "scatter_exponent": 8.0, "scatter": 0.3, "scatter_start": 40.0, "fog_scale": 4},
    {"sun_through_fog": True, "blur": "separate", "blur_radius": 3.0, "sky_affect": 0.5},
    {"blur": "single", "blur_radius": 2.0},   # the fused blur keeps the full composite
])
@pytest.mark.parametrize("msaa", [True, False])
def test_a_held_frame_equals_the_full_composite_of_the_same_look(renderer, effects, msaa):
    """Over the default scene, with the effects the held inputs keep (the lobe, the lit
    share, the direct sunlight, the sky's share): the same frame composited in full, as a
    still, within a level (the inputs are kept as RGBA16F), and most pixels exact."""
    from fogbank.model.presets import preset_dict
    look = preset_dict("default")
    look = {**look, "width": 320, "height": 180, "time": 7.0, "wind": {"direction": 70.0, "speed": 12.0},
            "effects": {**look["effects"], "blur": "off", **effects}}
    s = StillParams.model_validate(look)
    held = held_frame(renderer, "held-vs-full", msaa)(s).astype(int)
    renderer.drop_slot("full-composite")   # a scene pass of its own, with the held one's MSAA
    full = renderer.render(s, "full-composite", msaa).astype(int)
    d = np.abs(held - full).max(axis=2)
    assert int(d.max()) <= 1
    assert float((d > 0).mean()) <= 0.15
    # the frames differ from one at another time: the fog moves, and the check has teeth
    other = renderer.render(s.model_copy(update={"time": 9.0}), "full-composite", msaa).astype(int)
    assert float((np.abs(other - full).max(axis=2) > 2).mean()) > 0.01
    renderer.drop_slot("full-composite")
    assert renderer.ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize("change", [{"anisotropy": -0.4}, {"phase": "gawron", "scatter_exponent": 4.0},
                                    {"scatter_start": 60.0}, {"shafts": 0.3}, {"sky_affect": 0.2},
                                    {"aerial_perspective": 0.0}, {"aerial_perspective": 0.9}])
def test_an_effect_changed_over_held_fog_redraws_the_held_inputs(renderer, change):
    """Time runs, the camera stays, and an effect the held inputs keep changes: the fog
    stays held (it does not read the effect) and the next frame is the new look's."""
    from fogbank.model.presets import preset_dict
    look = preset_dict("default")
    look = {**look, "width": 320, "height": 180, "wind": {"direction": 70.0, "speed": 12.0},
            "effects": {**look["effects"], "scatter": 0.3}}
    before = StillParams.model_validate({**look, "time": 5.0})
    after = StillParams.model_validate({**look, "time": 6.0, "effects": {**look["effects"], **change}})
    renderer.drop_slot("held-change")
    for t in (4.0, 4.5, 5.0):
        renderer.render(before.model_copy(update={"time": t}), "held-change", True, hold_fog=True)
    f = renderer.begin(after, "held-change", True, hold_fog=True)
    for p in FRAME_PASSES:
        p.run(renderer, f)
    assert f.held_fog is not None
    held = f.image.astype(int)
    renderer.drop_slot("held-change")
    renderer.drop_slot("full-change")
    full = renderer.render(after, "full-change", True).astype(int)
    old = renderer.render(after.model_copy(update={"effects": before.effects}), "full-change", True).astype(int)
    assert int(np.abs(held - full).max()) <= 1
    assert int(np.abs(old - full).max()) > 3   # the effect shows: the check has teeth
    renderer.drop_slot("full-change")


@pytest.mark.parametrize("camera,layers,objects", [
    # 700 m up, looking down through height fog, a sphere and a drifting cosine below
    ({"position": (2.0, 700.0, -73.0), "yaw": 0.0, "pitch": -89.0, "fov": 10.0},
     [{"kind": "height", "density": 0.01, "falloff": 0.01, "base": 0.0},
      {"kind": "sphere", "center": (-40.0, 200.0, -90.0), "radius": 60.0, "density": 0.01},
      {"kind": "cosine", "density": 0.002, "c0": 1.0, "scale": 30.0, "wind": True,
       "terms": [{"amp": 0.9, "k": (0.3, 1.1, 0.2), "phase": 0.5}]}],
     {0, 1, 2, 3, 4}),
    FAR_CAMERA,   # 12.7 km out at a late time (tests/calibration.py)
])
def test_held_frames_from_high_and_far_cameras_at_a_late_time(renderer, camera, layers, objects):
    still = calibration_still(layers=layers, camera=camera, time=3.7e5,
                              effects={"scatter": 0.0, "sky_distance": 300.0})
    assert check_pixels(renderer, still, min_share=0.6, render=held_frame(renderer, "held-far")) == objects


@pytest.mark.parametrize("scale,size", [(2, (320, 180)), (4, (203, 117))])
def test_the_bilinear_tiles_are_those_whose_kept_weights_are_bilinear(renderer, scale, size):
    """The held composite blends bilinearly on the tiles that passes/held_edges.frag leaves
    unmarked: its marks, as the held fog's depths, against the tiles found in float64 from
    the kept weights W (an odd size: the last tiles are partial)."""
    from fogbank.model.presets import preset_dict
    from fogbank.render.passes.composite import HELD_EDGE_WEIGHT
    from fogbank.render.targets import SILHOUETTE_TILE as TILE
    look = preset_dict("default")
    w, h = size
    look = {**look, "width": w, "height": h, "time": 7.0, "wind": {"direction": 70.0, "speed": 12.0},
            "effects": {**look["effects"], "fog_scale": scale}}
    s = StillParams.model_validate(look)
    renderer.drop_slot("held-edges")
    for t in (6.0, 6.5, 7.0):
        renderer.render(s.model_copy(update={"time": t}), "held-edges", True, hold_fog=True)
    held = renderer.caches.gbuffer("held-edges", w, h, True).held[scale]
    assert held.edges_key == held.key and held.edges.size == (w, h)
    with_edges = held.nbytes()
    edges, held.edges = held.edges, None
    assert with_edges - held.nbytes() == w * h * 4   # the depth24 counts in the cache's budget
    held.edges = edges
    weights = np.frombuffer(held.inputs.color_attachments[1].read(), np.float16).reshape(h, w, 4)
    depth_fbo = renderer.ctx.framebuffer(depth_attachment=held.edges)
    depth = np.frombuffer(depth_fbo.read(components=1, attachment=-1, dtype="f4"), np.float32).reshape(h, w)
    renderer.caches.park()
    depth_fbo.release()
    # the bilinear weights of the four fog texels around each pixel, k = (k & 1, k >> 1)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    fx, fy = [(c + 0.5) / scale - 0.5 - np.floor((c + 0.5) / scale - 0.5) for c in (x, y)]
    bilinear = np.stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy], axis=-1)
    dev = np.abs(weights.astype(np.float64) - bilinear).max(axis=-1)
    rows, cols = -(-h // TILE), -(-w // TILE)
    padded = np.zeros((rows * TILE, cols * TILE))
    padded[:h, :w] = dev
    tile_dev = padded.reshape(rows, TILE, cols, TILE).max(axis=(1, 3))
    expected = np.repeat(np.repeat(tile_dev > HELD_EDGE_WEIGHT, TILE, 0), TILE, 1)[:h, :w]
    # depth24: 0.25 and 0.75 to within a unit of 2^-24
    assert np.allclose(sorted(np.unique(depth)), [0.25, 0.75], atol=2.0 ** -23, rtol=0.0)
    marked = depth < 0.5
    exact = np.abs(np.repeat(np.repeat(tile_dev, TILE, 0), TILE, 1)[:h, :w] - HELD_EDGE_WEIGHT) > 1e-6
    assert int((marked != expected)[exact].sum()) == 0
    assert 0.02 < float(marked.mean()) < 0.98   # both draws have pixels: the check has teeth
    renderer.drop_slot("held-edges")


@pytest.mark.parametrize("case", [
    {"width": 1, "height": 1, "time": 3.7e5, "fog_scale": 2},
    {"width": 5, "height": 7, "time": 9.9e5, "fog_scale": 4,
     "camera": {"position": (2.0, 700.0, -73.0), "yaw": 0.0, "pitch": -89.0, "fov": 10.0}},
    {"width": 203, "height": 117, "time": 9.9e5, "fog_scale": 4, "blur": "separate",
     "camera": {"position": (9900.0, 900.0, -9000.0), "yaw": 140.0, "pitch": -3.0, "fov": 40.0}},
    {"width": 640, "height": 2, "time": 3.0, "fog_scale": 2,
     "camera": {"position": (-35.0, 36.0, 85.0), "yaw": 30.0, "pitch": -11.0, "fov": 120.0}},
])
def test_held_frames_across_the_domain_equal_the_full_composite(renderer, case):
    """The held composite's bilinear and kept draws over the schema's extremes: a 1x1 frame,
    slivers, a camera 13 km out and one 700 m up, times up to 9.9e5 s, fog scales 2 and 4,
    with three layers of kinds drawn at random (each under the wind): the same frame
    composited in full, within a level."""
    import json
    from fogbank.kinds import KINDS
    from fogbank.model.presets import preset_dict
    rng = np.random.default_rng(case["width"] * 31 + case["height"])
    kinds = sorted(k for k in KINDS if k != "particles")
    layers = [{**json.loads(KINDS[kinds[j]].sample(rng).model_dump_json()), "wind": True}
              for j in rng.choice(len(kinds), 3)]
    look = preset_dict("default")
    look.update({k: case[k] for k in ("width", "height", "time", "camera") if k in case})
    look.update(layers=look["layers"] + layers, wind={"direction": 70.0, "speed": 12.0},
                effects={**look["effects"], "fog_scale": case["fog_scale"], "blur": case.get("blur", "off")})
    s = StillParams.model_validate(look)
    held = held_frame(renderer, "held-domain")(s).astype(int)
    renderer.drop_slot("full-domain")
    full = renderer.render(s, "full-domain", True).astype(int)
    renderer.drop_slot("full-domain")
    assert held.shape == full.shape == (case["height"], case["width"], 3)
    assert int(np.abs(held - full).max()) <= 1
    assert renderer.ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize("blur", ["off", "separate"])
def test_held_two_surface_pixels_are_listed_and_composited_in_place(renderer, blur):
    """The held composite draws the pixels with two surfaces packed (HeldFog.far_pixels)
    and copies them into place: the list holds exactly the pixels whose near coverage is
    below 1, each once, its padding a listed pixel, each tile's first place and mask find
    every pixel's place in it, the bytes count;
    and at those pixels the held frame is the full composite's within a level (without
    the copy, 53-66 levels off)."""
    from fogbank.model.presets import preset_dict
    from fogbank.render.targets import FAR_LIST_WIDTH
    look = preset_dict("default")
    look = {**look, "width": 203, "height": 117, "time": 7.0, "wind": {"direction": 70.0, "speed": 12.0},
            "effects": {**look["effects"], "blur": blur}}
    s = StillParams.model_validate(look)
    renderer.drop_slot("held-far")
    for t in (5.5, 6.0, 6.5):
        renderer.render(s.model_copy(update={"time": t}), "held-far", True, hold_fog=True)
    held = renderer.render(s, "held-far", True, hold_fog=True).astype(int)
    g = renderer.caches.gbuffer("held-far", s.width, s.height, s.effects.sun_through_fog)
    h = g.held[s.effects.fog_scale]
    assert h.inputs_key is not None
    cover = np.frombuffer(g.far_color.read(), np.float16).reshape(s.height, s.width, 4)[..., 3]
    two = cover < 1.0
    n = int(two.sum())
    assert h.far_count == n and n > 50
    listed = np.frombuffer(h.far_list.read(), np.int32).reshape(-1, 2)
    assert len(listed) == -(-n // FAR_LIST_WIDTH) * FAR_LIST_WIDTH
    xs, ys = listed[:n, 0], listed[:n, 1]
    assert bool(two[ys, xs].all()) and len(set(zip(xs.tolist(), ys.tolist()))) == n
    assert bool(two[listed[n:, 1], listed[n:, 0]].all())   # the padding repeats a listed pixel
    # each tile's (first place, mask): a listed pixel's place is the first plus the tile's
    # listed pixels before it (far_scatter.frag), the mask is the tile's two-surface pixels
    tiles = np.frombuffer(h.far_tiles.read(), np.int32).reshape(h.far_tiles.height, h.far_tiles.width, 2)
    for i, (x, y) in enumerate(zip(xs.tolist(), ys.tolist())):
        first, mask = tiles[y // 4, x // 4]
        k = (y % 4) * 4 + x % 4
        assert (mask >> k) & 1 == 1 and first + bin(int(mask) & ((1 << k) - 1)).count("1") == i
    for ty in range(tiles.shape[0]):
        for tx in range(tiles.shape[1]):
            block = two[ty * 4:ty * 4 + 4, tx * 4:tx * 4 + 4]
            bits = sum(1 << (r * 4 + c) for r, c in zip(*np.nonzero(block)))
            assert int(tiles[ty, tx, 1]) == bits
    with_far = h.nbytes()
    far_tiles, h.far_tiles = h.far_tiles, None
    out = {"off": 4, "separate": 8}[blur]   # RGBA8 for the output, RGBA16F before the blur
    assert set(h.far_out) == {"f1" if blur == "off" else "f2"}
    assert with_far - h.nbytes() == -(-s.width // 4) * -(-s.height // 4) * 8 + len(listed) * (8 + out)
    h.far_tiles = far_tiles
    renderer.drop_slot("full-far")
    full = renderer.render(s, "full-far", True).astype(int)
    renderer.drop_slot("full-far")
    renderer.drop_slot("held-far")
    assert int(np.abs(held - full).max()) <= 1
    assert renderer.ctx.error == "GL_NO_ERROR"
