"""The fog pass (render/passes/fog.py) of a stream whose camera stays still: the layers
that do not change with time are held, and each frame draws the others over them. The
held frames' fog texels against the float64 reference at each frame's own time (rays
from the hand-written camera), and the held sums against every change that must redraw
them."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.kinds import KINDS
from fogbank.kinds.packing import changes_with_time, split_by_time
from fogbank.kinds.reference import log_layer, transmittance as reference
from fogbank.model.params import StillParams
from fogbank.render.passes import CompositePass, FogFilterPass, FogPass, LightPass, ParticlesPass, ResolvePass, \
    ScenePass, ShadowPass, SkyPass
from fogbank.render.probes import fog_texels
from hand import hand_rays

W, H = 320, 180
SCENE_PASSES = (ShadowPass(), ScenePass(), SkyPass(), ResolvePass())

# every way a layer changes with time (wind, its own drift, a simulation) and every way it
# does not, the direct kinds and a carving body among them
LOOK = {
    "width": W, "height": H, "time": 3.0,
    "camera": {"position": (-35.0, 36.0, 85.0), "yaw": 30.0, "pitch": -11.0, "fov": 60.0},
    "wind": {"direction": 70.0, "speed": 4.0},
    "sun": {"azimuth": 30.0, "elevation": 20.0},
    "effects": {"sun_through_fog": True, "shafts": 1.0, "scatter": 0.04, "sky_distance": 500.0},
    "layers": [
        {"kind": "height", "density": 0.02, "falloff": 0.15, "base": 2.0},
        # its second term is a vertical wave, across the level wind: held (cosine split_by_time)
        {"kind": "cosine", "density": 0.004, "c0": 1.0, "scale": 20.0, "wind": True,
         "terms": [{"amp": 0.6, "k": (1.0, 2.0, 0.5), "phase": 0.3}, {"amp": 0.3, "k": (0.0, 1.5, 0.0), "phase": -0.4}]},
        {"kind": "ellipsoid", "center": (10.0, 15.0, 20.0), "radii": (40.0, 12.0, 30.0), "carve": 0.7,
         "edge_fade": 0.5},
        # low = high: its noise does not vary it (a frame filters distant noise by the texel's
        # footprint, which the float64 reference does not)
        {"kind": "distance", "start": 5.0, "distance": 400.0, "exponent": 0.8, "low": 0.3, "high": 0.3,
         "max": 0.3, "noise_scale": 40.0},
        {"kind": "sphere", "center": (30.0, 20.0, 10.0), "radius": 30.0, "density": 0.02, "wind": True},
        {"kind": "potential", "shape": "point", "center": (-20.0, 10.0, 0.0), "strength": 0.5, "c": 30.0,
         "e": 0.05},
    ],
}


def still(**patch) -> StillParams:
    return StillParams.model_validate({**LOOK, **patch})


def fog_pass(renderer, s: StillParams, slot: str, hold: bool = True):
    """The scene passes (held while the camera stays) and the frame's fog passes, as in a
    stream frame (`hold`) or a still."""
    f = renderer.begin(s, slot=slot, msaa=True, hold_fog=hold)
    for p in SCENE_PASSES + (LightPass(), FogPass(), FogFilterPass(), ParticlesPass()):
        p.run(renderer, f)
    renderer.keep_only(f)
    return f


def texel_rays(s: StillParams, fog: np.ndarray):
    """Each fog texel's ray (hand-written camera) and length, bottom row first."""
    h, w = fog.shape[:2]
    py, px = np.mgrid[0:h, 0:w]
    dirs = hand_rays(s.camera, px.ravel(), py.ravel(), w, h)
    invd = fog[..., 1].ravel().astype(np.float64)
    d = np.where(invd > 0, 1.0 / np.maximum(invd, 1e-30), s.effects.sky_distance)
    return np.broadcast_to(np.asarray(s.camera.position, float), dirs.shape), dirs, d, invd


def toward_the_sun(fog):
    """The fog a surface's sunlight crosses (fog/transmittance.glsl fogSunTransmittance):
    the density layers alone, without the view's start and cutoff distances."""
    layers = [l for l in fog.layers if KINDS[l.kind].optical_depth is not None]
    effects = fog.effects.model_copy(update={"start_distance": 0.0, "cutoff_distance": 0.0, "max_opacity": 1.0})
    return fog.model_copy(update={"layers": layers, "effects": effects})


def check_against_reference(s: StillParams, f) -> None:
    """The frame's raw T and T toward the sun at every fog texel against float64."""
    fog = fog_texels(f)
    eye, dirs, d, invd = texel_rays(s, fog)
    want = reference(s.fog(), eye, dirs, d, s.time)
    assert float(np.abs(fog[..., 0].ravel() - want).max()) <= 2e-4
    assert float(np.ptp(want)) > 0.3   # the layers are in view: the check has teeth
    ground = invd > 0
    if not s.effects.sun_through_fog:   # no fog toward the sun: T_sun is 1 everywhere
        assert np.all(fog[..., 2] == 1.0)
        return
    P = eye[ground] + dirs[ground] * d[ground, None]
    L = np.broadcast_to(s.sun.direction(), P.shape)
    sun_want = reference(toward_the_sun(s.fog()), P, L, np.full(len(P), s.effects.sky_distance), s.time)
    assert float(np.abs(fog[..., 2].ravel()[ground] - sun_want).max()) <= 2e-4
    assert np.all(fog[..., 2].ravel()[~ground] == 1.0)


def test_layers_that_change_with_time_are_the_sliding_and_the_simulated():
    s = still(layers=LOOK["layers"] + [
        {"kind": "noise", "density": 0.01, "scale": 30.0, "drift": (0.0, 0.0, 0.5)},
        {"kind": "particles", "count": 20, "emitter": (0.0, 1.0, -40.0)},
        {"kind": "homogeneous", "density": 0.001, "wind": True, "enabled": False}])
    fog = s.fog()
    assert [changes_with_time(l, fog) for l in fog.layers] == [False, True, False, False, True, False, True, True,
                                                                True]
    calm = fog.model_copy(update={"wind": fog.wind.model_copy(update={"speed": 0.0})})
    assert [changes_with_time(l, calm) for l in calm.layers][:6] == [False] * 6
    held, moving = split_by_time(fog)
    assert [l.kind for l in held.layers] == ["height", "cosine", "ellipsoid", "distance", "potential"]
    # the disabled one left out; the still carving body carves both parts
    assert [l.kind for l in moving.layers] == ["cosine", "ellipsoid", "sphere", "noise", "particles"]
    # the cosine's term across the wind is held with the constant; the other moves alone
    assert [(t.k, l.c0, l.wind) for l in held.layers[1:2] for t in l.terms] == [((0.0, 1.5, 0.0), 1.0, False)]
    assert [(t.k, l.c0, l.wind) for l in moving.layers[:1] for t in l.terms] == [((1.0, 2.0, 0.5), 0.0, True)]
    # a moving carving body takes a changing share of every layer: then all of them move
    drifting = fog.model_copy(update={"layers": [l.model_copy(update={"wind": True}) if l.kind == "ellipsoid" else l
                                                 for l in fog.layers]})
    held2, moving2 = split_by_time(drifting)
    assert held2.layers == [] and len(moving2.layers) == 8
    # their optical depths add up to the layer's (float64, random rays at a late time)
    rng = np.random.default_rng(5)
    O, w = rng.normal(size=(64, 3)) * 200.0, rng.normal(size=(64, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    d, t = rng.uniform(1.0, 900.0, 64), np.full(64, 1.0e5)
    parts = log_layer(held.layers[1], fog, O, w, d, t) + log_layer(moving.layers[0], fog, O, w, d, t)
    assert np.allclose(parts, log_layer(fog.layers[1], fog, O, w, d, t), rtol=1e-9, atol=1e-12)


def test_a_still_camera_holds_the_fog_that_does_not_move_and_each_frame_matches_the_reference(renderer):
    held = []
    for i in range(4):
        s = still(time=3.0 + 0.5 * i)
        f = fog_pass(renderer, s, "held-ref")
        check_against_reference(s, f)   # before the next frame draws into the same fog target
        held.append(f.held_fog is not None)
    # the first frame draws the scene, the second asks for the held sums, the third draws them
    assert held == [False, False, True, True]
    # the held frame's texels are the whole fog's, up to float32 rounding of the sums' order
    got = fog_texels(f).copy()
    whole = fog_texels(fog_pass(renderer, still(time=4.5), "held-ref-whole", hold=False))
    assert float(np.abs(got - whole)[..., :3].max()) <= 1e-5
    # the in-scattered light: a held grid places each slice's points by the held layers'
    # optical depth (passes/light.frag LIGHT_STAGE 2), a whole one by all of it; the two
    # estimates agree within the grid's own contract (tests/gl/test_light.py: 95% within 0.03)
    dj = np.abs(got - whole)[..., 3]
    assert float(dj.max()) <= 0.03 and float(dj.mean()) <= 0.002
    renderer.drop_slot("held-ref")
    renderer.drop_slot("held-ref-whole")
    assert renderer.ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize("change", [
    {"layers": [dict(LOOK["layers"][0], density=0.05)] + LOOK["layers"][1:]},   # a held layer
    {"layers": LOOK["layers"][:3] + LOOK["layers"][4:]},                         # one less
    {"sun": {"azimuth": 200.0, "elevation": 35.0}},
    {"camera": dict(LOOK["camera"], yaw=31.0)},
    {"effects": dict(LOOK["effects"], fog_scale=2)},
    {"effects": dict(LOOK["effects"], shafts=0.0, start_distance=30.0)},
    {"effects": dict(LOOK["effects"], sky_distance=300.0)},
    {"density": 0.5},
    {"wind": {"speed": 0.0}},   # the wind-sensitive layers stop: they join the held ones
    {"effects": dict(LOOK["effects"], cutoff_distance=150.0, cutoff_mode="fog")},
    {"effects": dict(LOOK["effects"], sun_through_fog=False)},
    {"layers": [dict(LOOK["layers"][0], enabled=False)] + LOOK["layers"][1:]},
])
def test_a_change_is_never_drawn_over_stale_held_fog(renderer, change):
    for i in range(3):
        f = fog_pass(renderer, still(time=3.0 + i), "held-stale")
    assert f.held_fog is not None
    for i in range(3):
        s = still(time=6.0 + i, **change)
        f = fog_pass(renderer, s, "held-stale")
        check_against_reference(s, f)
    renderer.drop_slot("held-stale")


def test_stills_never_hold_fog(renderer):
    for i in range(3):
        f = renderer.begin(still(time=3.0 + i), slot="still-slot", msaa=True)
        for p in SCENE_PASSES + (FogPass(),):
            p.run(renderer, f)
    assert f.held_fog is None and f.gbuffer.held == {}
    renderer.drop_slot("still-slot")


def test_held_fog_counts_against_the_cache_and_goes_with_its_session(renderer):
    renderer.release_caches()
    for i in range(3):
        f = fog_pass(renderer, still(time=3.0 + i), "held-bytes")
    CompositePass().run(renderer, f)   # the held composite's inputs too
    h = f.held_fog
    fw, fh = h.sums.width, h.sums.height
    assert (fw, fh) == (W // still().effects.fog_scale, H // still().effects.fog_scale)
    # the sums, tauDirect (distance fog),
    # the composite's inputs at full size (RGBA32UI + RGBA16F: the bytes of the textures it
    # made), and, where the scene pass
    # has pixels with two surfaces, their tiles' places and masks (RG32I a 4x4 tile), list
    # (RG32I) and composite (RGBA8)
    listed = h.far_list.width * h.far_list.height if h.far_list is not None else 0
    tiles = -(-W // 4) * -(-H // 4)
    assert (h.far_count > 0) == f.gbuffer.two_surfaces
    inputs = sum(t.components * int(t.dtype[1:]) for t in h.inputs.color_attachments)
    assert inputs == 16 + 8
    assert h.nbytes() == (fw * fh * (16 + 4) + W * H * inputs
                          + (tiles * 8 + listed * (8 + 4) if f.gbuffer.two_surfaces else 0))
    assert f.gbuffer.nbytes() >= h.nbytes()
    moved = fog_pass(renderer, still(time=6.0, camera=dict(LOOK["camera"], yaw=40.0)), "held-bytes")
    assert moved.gbuffer is f.gbuffer and f.gbuffer.held == {}   # the scene drawn anew: its held fog went
    assert renderer.ctx.error == "GL_NO_ERROR"
    for i in range(3):
        f = fog_pass(renderer, still(time=7.0 + i), "held-bytes")
    CompositePass().run(renderer, f)
    before = renderer.cache_bytes()
    renderer.drop_slot("held-bytes")
    assert renderer.cache_bytes() <= before - f.held_fog.nbytes()
    assert renderer.ctx.error == "GL_NO_ERROR"


def test_where_nothing_moves_the_fog_target_itself_is_held(renderer):
    """No wind and no simulated layer: every frame's fog is the same, so the held fog is
    the frame's filtered fog target (no program compiled for it), and later frames draw no
    fog (and no light grid): their texels are the reference's at each time, and a jittered
    look's (volume noise) are the whole fog's filtered ones, to the bit."""
    calm = {"wind": {"speed": 0.0}}
    held = []
    for i in range(4):
        s = still(time=3.0 + 0.5 * i, **calm)
        f = fog_pass(renderer, s, "held-whole")
        check_against_reference(s, f)
        held.append(f.held_fog is not None and f.held_fog.whole)
    assert held == [False, False, True, True]
    compiled = renderer.programs.compiled
    noisy = dict(calm, layers=LOOK["layers"] + [{"kind": "noise", "mode": "volume", "density": 0.01, "samples": 8,
                                                 "scale": 40.0}])
    for i in range(4):
        f = fog_pass(renderer, still(time=3.0 + 0.5 * i, **noisy), "held-whole")
    assert f.held_fog.whole and f.filtered == {"T"} and f.light is None
    got = fog_texels(f).copy()
    whole = fog_texels(fog_pass(renderer, still(time=4.5, **noisy), "held-whole-ref", hold=False))
    assert float(np.abs(got - whole).max()) == 0.0
    # the noisy look's own fog and light grid programs (and the filter's, at its first use): no held one
    assert renderer.programs.compiled - compiled <= 3
    renderer.drop_slot("held-whole")
    renderer.drop_slot("held-whole-ref")
