"""Rendered frames against independent references: the calibration scene's pixels against
the blend of scene colour and fog colour by the reference T, computed from an analytic
ray cast in float64; plus determinism, fog scale and blur sanity."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.scene import camera as cam
from fogbank.scene import meshes as scenes
from fogbank.kinds.reference import transmittance as reference
from fogbank.model.params import StillParams
from fogbank.model.fields import srgb_to_linear
from calibration import FAR_CAMERA, H, W, calibration_still, srgb_to_linear_array
from calibration import check_pixels as _check_pixels
from calibration import to_srgb as _to_srgb
from hand import cast, hand_rays


def test_the_projection_matches_a_hand_written_camera():
    """The renderer's view-projection matrix (the scene's raster) and view rays (the fog
    pass) against the hand-written camera, for random cameras and points."""
    from fogbank.model.params import Camera
    rng = np.random.default_rng(8)
    for _ in range(50):
        c = Camera(position=tuple(rng.uniform(-100, 100, 3)), yaw=float(rng.uniform(-360, 360)),
                   pitch=float(rng.uniform(-89, 89)), fov=float(rng.uniform(10, 120)))
        w_, h_ = int(rng.integers(16, 2000)), int(rng.integers(16, 2000))
        view = cam.view(c, w_, h_)
        px, py = rng.uniform(0, w_, 20), rng.uniform(0, h_, 20)
        assert np.abs(view.ray(px, py, w_, h_) - hand_rays(c, px, py, w_, h_)).max() < 1e-12
        # a point on each hand ray, 5-500 m out, projects back to its pixel centre
        pts = np.asarray(c.position) + hand_rays(c, px, py, w_, h_) * rng.uniform(5, 500, (20, 1))
        clip = np.c_[pts, np.ones(20)] @ view.view_proj.T
        ndc = clip[:, :2] / clip[:, 3:4]
        got = np.c_[(ndc[:, 0] + 1) / 2 * w_ - 0.5, (ndc[:, 1] + 1) / 2 * h_ - 0.5]
        assert np.abs(got - np.c_[px, py]).max() < 1e-6 * max(w_, h_)


@pytest.mark.parametrize("layers", [
    [{"kind": "homogeneous", "density": 0.012}],
    [{"kind": "height", "density": 0.05, "falloff": 0.2, "base": 0.0},
     {"kind": "sphere", "center": (0.0, 3.0, -40.0), "radius": 15.0, "density": 0.08}],
    [{"kind": "cosine", "density": 0.01, "c0": 1.0, "scale": 10.0,
      "terms": [{"amp": 0.8, "k": (1.0, 2.0, 0.5), "phase": 0.3}]},
     {"kind": "distance", "start": 5.0, "distance": 150.0, "exponent": 0.8, "low": 0.5,
      "high": 0.9, "max": 0.7, "noise_scale": 40.0}],
    # particles go through the quad pass; density and max opacity through the composite
    [{"kind": "particles", "count": 300, "emitter": (0.0, 1.0, -40.0), "spread": 70.0, "speed": 3.0,
      "radius": 5.0, "alpha": 0.5, "life_min": 30, "life_max": 60},
     {"kind": "homogeneous", "density": 0.004}],
])
@pytest.mark.parametrize("effects", [{}, {"density": 1.7, "max_opacity": 0.8, "start_distance": 12.0},
                                     {"cutoff_distance": 60.0, "cutoff_mode": "fog", "max_opacity": 0.9},
                                     {"cutoff_distance": 60.0, "cutoff_mode": "clear"},
                                     {"sky_affect": 0.3}])
def test_calibration_pixels_match_reference_blend(renderer, layers, effects):
    still = calibration_still(layers=layers, time=4.0, density=effects.get("density", 1.0))
    eff = {k: v for k, v in effects.items() if k != "density"}
    still = still.model_copy(update={"effects": still.effects.model_copy(update=eff)})
    objects = _check_pixels(renderer, still)
    assert objects == {-1, 0, 1, 2, 3, 4}    # every object is checked


@pytest.mark.parametrize("camera,layers,objects", [
    # 700 m up, looking down on the boxes through height fog and a sphere below
    ({"position": (2.0, 700.0, -73.0), "yaw": 0.0, "pitch": -89.0, "fov": 10.0},
     [{"kind": "height", "density": 0.01, "falloff": 0.01, "base": 0.0},
      {"kind": "sphere", "center": (-40.0, 200.0, -90.0), "radius": 60.0, "density": 0.01}],
     {0, 1, 2, 3, 4}),
    FAR_CAMERA,   # 12.7 km out at a late time (tests/calibration.py)
])
def test_calibration_from_high_and_far_cameras(renderer, camera, layers, objects):
    still = calibration_still(layers=layers, camera=camera, time=3.7e5,
                              effects={"scatter": 0.0, "sky_distance": 300.0})
    assert _check_pixels(renderer, still, min_share=0.6) == objects


def test_same_params_same_pixels(renderer):
    still = StillParams(width=W, height=H, layers=[{"kind": "height"}, {"kind": "particles"}], time=3.0)
    a = renderer.render(still)
    renderer.render(still.model_copy(update={"time": 9.0}))
    b = renderer.render(still)
    assert np.array_equal(a, b)


def test_fog_changes_the_picture_and_density_zero_removes_it(renderer):
    clear = StillParams(width=W, height=H, layers=[])
    foggy = StillParams(width=W, height=H, layers=[{"kind": "homogeneous", "density": 0.05}])
    none = foggy.model_copy(update={"density": 0.0})
    a, b, c = (renderer.render(s).astype(int) for s in (clear, foggy, none))
    assert np.abs(a - b).mean() > 20
    assert np.array_equal(a, c)


@pytest.mark.parametrize("scale", [2, 4])
def test_fog_scale_upsample_close_to_full_resolution(renderer, scale):
    base = calibration_still(layers=[{"kind": "height", "density": 0.05, "falloff": 0.1}])
    full = renderer.render(base).astype(int)
    low = renderer.render(base.model_copy(update={"effects": base.effects.model_copy(
        update={"fog_scale": scale})})).astype(int)
    diff = np.abs(full - low).max(axis=2)
    # the depth-aware upsample keeps object edges: almost every pixel within 3/255
    assert np.mean(diff <= 3) > 0.97
    assert np.percentile(diff, 99.5) <= 12


@pytest.mark.parametrize("mode", ["single", "separate"])
def test_blur_softens_edges_only_where_there_is_fog(renderer, mode):
    base = calibration_still(layers=[{"kind": "homogeneous", "density": 0.03}])
    sharp = renderer.render(base).astype(float)
    eff = base.effects.model_copy(update={"blur": mode, "blur_radius": 16.0})
    soft = renderer.render(base.model_copy(update={"effects": eff})).astype(float)
    diff = np.abs(soft - sharp).max(axis=2)
    # object edges change (sigma is ~2.4 px at the red box), flat interiors do not
    flat = (np.abs(np.diff(sharp, axis=0, prepend=sharp[:1])).max(axis=2) < 1) & \
           (np.abs(np.diff(sharp, axis=1, prepend=sharp[:, :1])).max(axis=2) < 1)
    interior = flat.copy()
    for k in range(1, 8):   # 7 px away from any edge
        interior &= np.roll(flat, k, 0) & np.roll(flat, -k, 0) & np.roll(flat, k, 1) & np.roll(flat, -k, 1)
    # single blurs the scene under the fog (flat here); separate blurs the foggy image,
    # whose fog ramp along the ground is curved, so a Gaussian moves it a little
    assert diff[interior].max() <= (2 if mode == "single" else 5)
    assert diff.max() >= 10
    if mode == "separate":   # blurring the foggy image lowers its gradient energy
        def energy(img):
            return (np.diff(img.mean(axis=2), axis=1) ** 2).sum()
        assert energy(soft) < 0.8 * energy(sharp)
    # no fog: no blur (separate: up to 1 level at silhouettes, whose two surfaces' mix is
    # stored in the RGBA16F linear target before the output's rounding)
    clear = base.model_copy(update={"layers": []})
    still_diff = np.abs(renderer.render(clear).astype(int) -
                        renderer.render(clear.model_copy(update={"effects": eff})).astype(int))
    assert int(still_diff.max()) <= (0 if mode == "single" else 1)


def test_any_valid_look_renders(renderer):
    """Random valid looks (all kinds, extreme sizes and effects) render without a GL error,
    and their fog pass gives a finite transmittance in [0, 1] at every texel (a NaN would
    show only as a black pixel in the uint8 image)."""
    from fogbank.render.probes import fog_only
    from draws import ALL, random_layer
    rng = np.random.default_rng(42)
    for i in range(64):   # more layer variants than the program cache keeps (48)
        layers = [random_layer(str(rng.choice(ALL)), rng) for _ in range(int(rng.integers(0, 6)))]
        still = StillParams(
            width=int(rng.choice([1, 2, 3, 17, 64, 129])), height=int(rng.choice([1, 5, 33, 64])),
            scene=str(rng.choice(["countryside", "calibration"])), layers=layers,
            time=float(rng.uniform(0, 1000)), density=float(rng.uniform(0, 20)),
            camera={"position": tuple(rng.uniform(-300, 300, 3)), "yaw": float(rng.uniform(-360, 360)),
                    "pitch": float(rng.uniform(-89, 89)), "fov": float(rng.uniform(10, 120))},
            effects={"fog_scale": int(rng.choice([1, 2, 4])),
                     "blur": str(rng.choice(["off", "single", "separate"])),
                     "blur_radius": float(rng.uniform(0, 16)), "start_distance": float(rng.uniform(0, 50)),
                     "max_opacity": float(rng.uniform(0, 1))})
        img = renderer.render(still)
        assert img.shape == (still.height, still.width, 3)
        assert renderer.ctx.error == "GL_NO_ERROR"
        _, T, _, _ = fog_only(renderer, still)
        assert bool(np.all(np.isfinite(T))) is True
        assert (float(T.min()) >= 0.0, float(T.max()) <= 1.0) == (True, True)


def test_preview_reuses_a_full_quality_scene_pass(renderer):
    still = StillParams(width=W, height=H, layers=[{"kind": "homogeneous", "density": 0.02}])
    full = renderer.render(still, slot="preview-test", msaa=True)
    g = renderer.caches.gbuffer("preview-test", W, H)
    key = g.scene_key
    preview = renderer.render(still, slot="preview-test", msaa=False)
    assert g.scene_key == key                       # no redraw without MSAA
    assert np.array_equal(full, preview)            # and the same pixels
    moved = still.model_copy(update={"camera": still.camera.model_copy(update={"yaw": 9.0})})
    renderer.render(moved, slot="preview-test", msaa=False)
    assert g.scene_key[3] is False                  # a new view: the cheap pass (no MSAA)


def test_render_targets_are_released_with_their_attachments_and_held_to_budget(renderer):
    """Stills at 24 sizes: the caches stay within their byte budget and memory returns
    (releasing framebuffers without their renderbuffers and textures grew RSS by the
    whole target set per size: 20 stills at 1280..1299 x 720 took 164 MB to 1.84 GB)."""
    from fogbank.workers import worker
    from fogbank.render.renderer import Renderer
    worker._fix_mmap_threshold()
    r = Renderer(renderer.ctx, cache_bytes=96 << 20)
    r.render(StillParams(width=1280, height=720))
    warm = worker.rss_bytes()
    for w in range(1281, 1305):
        r.render(StillParams(width=w, height=720))
        assert r.ctx.error == "GL_NO_ERROR"
        assert r.cache_bytes() <= 2 * (96 << 20)
    grown = worker.rss_bytes() - warm
    r.release_caches()
    assert r.ctx.error == "GL_NO_ERROR"
    assert grown < 300 << 20, grown


def test_growing_ray_targets_and_dropping_caches_leave_no_gl_error(renderer):
    """Releasing the bound framebuffer left GL_INVALID_OPERATION behind: 100 rays then
    16384 rays failed with a 500."""
    import numpy as np
    from fogbank.model.params import FogParams
    fog = FogParams()
    for n in (1, 100, 16384):
        O, W = np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0], (n, 1))
        T = renderer.transmittance(fog, O, W, np.full(n, 10.0), np.zeros(n))
        assert renderer.ctx.error == "GL_NO_ERROR"
        assert T.shape == (n,)
    renderer.render(StillParams(width=64, height=48), slot="s1")
    renderer.drop_slot("s1")
    renderer.release_caches()
    assert renderer.ctx.error == "GL_NO_ERROR"


def fog_texels(renderer, still):
    """The frame's fog pass and particle quads (raw T per fog texel, bottom row first),
    with each texel's ray from the hand-written camera: (T, eye, directions, lengths)."""
    from fogbank.render.probes import fog_only
    _, T, invd, view = fog_only(renderer, still)
    h, w = T.shape
    py, px = np.mgrid[0:h, 0:w]
    dirs = hand_rays(still.camera, px.ravel(), py.ravel(), w, h)
    d = np.where(invd.ravel() > 0, 1.0 / np.maximum(invd.ravel().astype(np.float64), 1e-30),
                 still.effects.sky_distance)
    return T.ravel(), np.broadcast_to(view.eye, dirs.shape), dirs, d


def test_particle_quads_match_the_reference_at_every_fog_texel(renderer):
    """The pass that draws particles in frames (instanced quads multiplied into the fog
    target) against the float64 product of the particles' clarities along each texel's
    ray (hand-written camera), the particle state simulated independently of the renderer;
    the particles grow from 3 m at birth to 7.5 m at the end of their lives."""
    from fogbank.kinds.particle_motion import simulate
    from fogbank.scene import terrain
    still = calibration_still(time=4.0, density=1.3, layers=[
        {"kind": "particles", "count": 300, "emitter": (0.0, 1.0, -40.0), "spread": 70.0, "speed": 3.0,
         "radius": 3.0, "growth": 2.5, "alpha": 0.5, "life_min": 30, "life_max": 60}])
    T, eye, dirs, d = fog_texels(renderer, still)
    fog = still.fog()
    state = simulate(fog.layers[0], fog.time, fog.wind.vector(), terrain.flat, ages=True)
    want = reference(fog, eye, dirs, d, fog.time, states={0: state})
    err = np.abs(T - want)
    assert float(err.max()) <= 2e-4
    assert float(np.ptp(want)) > 0.3   # the particles cover part of the view: the check has teeth


def test_a_carved_frame_equals_its_rays_and_the_reference(renderer):
    """A carving ellipsoid around chimney-like smoke in homogeneous fog: the frame (fog
    pass, then the particle quads multiplied in) equals the rays API (particles inline)
    and the float64 reference, since a carving body takes depth from the density layers
    inside itself only, never from the direct ones."""
    from fogbank.kinds.particle_motion import simulate
    from fogbank.scene import terrain
    still = calibration_still(time=4.0, layers=[
        {"kind": "homogeneous", "density": 0.01},
        {"kind": "ellipsoid", "center": (0.0, 4.0, -40.0), "radii": (18.0, 10.0, 14.0), "carve": 1.0},
        {"kind": "particles", "count": 200, "emitter": (0.0, 1.0, -40.0), "spread": 60.0, "speed": 2.0,
         "radius": 2.5, "growth": 2.0, "alpha": 0.6, "life_min": 30, "life_max": 60}])
    T, eye, dirs, d = fog_texels(renderer, still)
    fog = still.fog()
    rays = renderer.transmittance(fog, eye, dirs, d, np.full(len(d), fog.time))
    state = simulate(fog.layers[2], fog.time, fog.wind.vector(), terrain.flat, ages=True)
    want = reference(fog, eye, dirs, d, fog.time, states={2: state})
    assert float(np.abs(T - rays).max()) <= 2e-4
    assert float(np.abs(T - want).max()) <= 2e-4
    carved = want[np.abs(want - 1.0) > 1e-3]
    assert float(np.ptp(want)) > 0.3 and len(carved) > 100   # fog, smoke and a clearing in view


def hand_phase(phase, mu, exponent, g):
    """The in-scattering lobe F: Gawron's max(0, mu)^e, or Henyey & Greenstein's phase
    function (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5) times 4 pi."""
    if phase == "gawron":
        return np.maximum(mu, 0.0) ** exponent
    return (1 - g * g) / (1 + g * g - 2 * g * mu) ** 1.5


@pytest.mark.parametrize("phase,start,g", [("gawron", 0.0, 0.0), ("gawron", 40.0, 0.0),
                                           ("henyey-greenstein", 0.0, 0.7),
                                           ("henyey-greenstein", 40.0, -0.4)])
def test_scatter_phase_color_and_start_distance(renderer, phase, start, g):
    """Gawron eqs. 5-8 by hand: every interior pixel of the calibration scene is
    T C + (1 - T) (C_fog + C_sun C_scatter s F(n . L)), n = p_s / |p_s|,
    p_s = (P - eye) + ScatterStartDist added to each component; T from the reference;
    F Gawron's power lobe or the Henyey-Greenstein phase function (hand_phase)."""
    still = calibration_still(layers=[{"kind": "homogeneous", "density": 0.015}],
                              sun={"azimuth": 10.0, "elevation": 12.0, "color": "#fff4e0", "intensity": 2.0})
    eff = still.effects.model_copy(update={"scatter": 0.7, "scatter_exponent": 6.0,
                                           "scatter_color": "#ff9a40", "scatter_start": start,
                                           "phase": phase, "anisotropy": g})
    still = still.model_copy(update={"effects": eff})
    img = renderer.render(still).astype(np.float64)
    py, px = np.mgrid[0:H, 0:W]
    w = hand_rays(still.camera, px.ravel(), (H - 1 - py).ravel(), W, H)
    eye = np.asarray(still.camera.position, dtype=np.float64)
    d, obj = cast(eye, w)
    obj = np.where(d < cam.FAR, obj, -1).reshape(H, W)
    same = np.ones((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= np.roll(np.roll(obj, dy, 0), dx, 1) == obj
    same[[0, -1], :] = same[:, [0, -1]] = False
    sel = same.ravel()
    d = np.where(obj.ravel() == -1, still.effects.sky_distance, d)[sel]
    ws = w[sel]
    T = reference(still.fog(), np.broadcast_to(eye, ws.shape), ws, d, still.time)
    albedo = {-1: scenes.CALIBRATION_SKY, 0: scenes.CALIBRATION_GROUND}
    albedo.update({i: c for i, (_, _, c) in enumerate(scenes.CALIBRATION_BOXES, start=1)})
    scene_lin = np.array([srgb_to_linear(albedo[o]) for o in obj.ravel()[sel]])
    L = still.sun.direction()
    ps = ws * d[:, None] + start
    n = ps / np.linalg.norm(ps, axis=1, keepdims=True)
    tint = np.array(srgb_to_linear("#fff4e0")) * 2.0 * np.array(srgb_to_linear("#ff9a40")) * 0.7
    glow = hand_phase(phase, n @ L, 6.0, g)
    fog = np.array(srgb_to_linear(still.fog_color)) + tint * glow[:, None]
    want = _to_srgb(T[:, None] * scene_lin + (1 - T[:, None]) * fog)
    err = np.abs(img.reshape(-1, 3)[sel] - want)
    assert err.max() <= 2.0
    assert float(glow.max() - glow.min()) > 0.2   # the scattering lobe varies across the view


def test_gawron_preset_scatters_its_own_colour():
    """Gawron's orange ScatterColor, not the sun's. Its start distance (eq. 5, tested by
    hand-computed pixels) is 0 since issue 32: it made a muddy yellow blotch in the
    foreground (tests/gl/test_presets.py test_gawron_scatter_is_orange)."""
    from fogbank.model.presets import preset_dict
    look = StillParams.model_validate(preset_dict("gawron-distance"))
    e = look.effects
    assert (e.scatter_color != "#ffffff", look.sun.color != e.scatter_color) == (True, True)


def test_output_is_dithered_so_flat_regions_average_to_their_true_value(renderer):
    """The 8-bit output is dithered by up to half a level (interleaved gradient noise):
    over the calibration scene's flat sky under homogeneous fog, whose exact colour v is
    the same at every pixel and lies 0.2 levels or more from a whole level, each pixel is
    within one level of v and their mean within 0.1 of it (plain rounding gives every pixel
    round(v), off by the same 0.2 or more); and the same look gives the same bytes."""
    still = calibration_still(layers=[{"kind": "homogeneous", "density": 0.0021}])
    img = renderer.render(still).astype(np.float64)
    assert np.array_equal(renderer.render(still), img.astype(np.uint8))
    T = np.exp(-0.0021 * still.effects.sky_distance)
    sky, fog = np.array(srgb_to_linear(scenes.CALIBRATION_SKY)), np.array(srgb_to_linear(still.fog_color))
    v = _to_srgb(T * sky + (1 - T) * fog)
    assert float(np.abs(np.round(v) - v).min()) >= 0.2
    top = img[:40, 20:-20].reshape(-1, 3)      # sky only: the boxes and ground are lower
    assert float(np.abs(top - v).max()) <= 1.0
    assert float(np.abs(top.mean(axis=0) - v).max()) <= 0.1


def test_sunlight_through_fog_is_dimmed_by_the_closed_forms_toward_the_sun(renderer):
    """effects.sun_through_fog: a surface's direct sunlight is multiplied by the fog's
    transmittance from it toward the sun over the sky distance. An ellipsoid cloud hangs
    above the eye (y 45-95 m), so no ground pixel's view ray meets fog (T = 1 there) while
    their rays toward the sun cross it. Each ground pixel is then A + T_sun S, where A is the
    same pixel with the sun's intensity at 0 (ambient only), A + S the pixel without
    sun_through_fog, and T_sun the float64 reference along the sun's direction from the
    pixel's surface point (hand-written camera, distance from the fog pass)."""
    from fogbank.render.probes import fog_only
    look = {"width": W, "height": H, "time": 0.0,
            "camera": {"position": (-15.0, 34.0, 95.0), "yaw": 5.0, "pitch": -18.0, "fov": 50.0},
            "sun": {"azimuth": 200.0, "elevation": 35.0, "color": "#fff1d6", "intensity": 3.0},
            "effects": {"scatter": 0.0, "sky_distance": 600.0},
            "layers": [{"kind": "ellipsoid", "center": (-15.0, 70.0, -20.0), "radii": (160.0, 25.0, 160.0),
                        "density": 0.03}]}
    lit = StillParams.model_validate(look)
    dimmed = StillParams.model_validate({**look, "effects": {**look["effects"], "sun_through_fog": True}})
    dark = StillParams.model_validate({**look, "sun": {**look["sun"], "intensity": 0.0}})
    lin = [srgb_to_linear_array(renderer.render(s)) for s in (lit, dimmed, dark)]
    _, Tview, invd, _ = fog_only(renderer, dimmed)
    py, px = np.mgrid[0:H, 0:W]
    w = hand_rays(lit.camera, px.ravel(), (H - 1 - py).ravel(), W, H)
    invd = invd[::-1].ravel().astype(np.float64)
    ground = (invd > 0) & (Tview[::-1].ravel() == 1.0)
    assert ground.mean() > 0.5
    eye = np.asarray(lit.camera.position, dtype=np.float64)
    P = eye + w[ground] / invd[ground, None]
    L = np.broadcast_to(lit.sun.direction(), P.shape)
    Tsun = reference(lit.fog(), P, L, np.full(len(P), 600.0), 0.0)
    assert float(np.mean(Tsun < 0.7)) > 0.3 and float(np.mean(Tsun > 0.95)) > 0.02   # cloud shadow and light
    A, C = lin[2].reshape(-1, 3)[ground], lin[0].reshape(-1, 3)[ground]
    want = _to_srgb(A + Tsun[:, None] * (C - A))
    got = _to_srgb(lin[1].reshape(-1, 3)[ground])
    err = np.abs(got - want)
    assert float(np.percentile(err, 99)) <= 1.5
    assert float((C - A).mean()) > 0.05       # the sun lights the ground: the test can tell


def test_single_pass_blur_has_no_ghosts(renderer):
    """The fused blur's 5x5 Gaussian taps were sigma apart on the full-resolution image, so
    at a large sigma a sharp edge became a staircase of five copies (the house showed
    ghosts at blur_radius 10). Across the bottom edge of the red box, where it meets the
    ground at the same depth (so the depth-aware weights let the blur cross it; sigma
    ~4.6 px at 640x360), the vertical gradient averaged over 12 columns is one ramp:
    within 3 sigma of the edge, the rows where it exceeds 20% of its peak form one run
    (a staircase of ghosts has flat steps between its copies: five runs before)."""
    density = 0.03
    still = calibration_still(layers=[{"kind": "homogeneous", "density": density}], width=640, height=360)
    still = still.model_copy(update={"effects": still.effects.model_copy(update={
        "blur": "single", "blur_radius": 16.0})})
    img = renderer.render(still).astype(np.float64)[..., 1]   # green: the red box is dark in it
    py, px = np.mgrid[0:360, 0:640]
    w = hand_rays(still.camera, px.ravel(), (359 - py).ravel(), 640, 360)
    d, obj = cast(np.asarray(still.camera.position, dtype=np.float64), w)
    red = obj.reshape(360, 640) == 1
    cols = np.nonzero(red.sum(axis=0) > 10)[0]
    cols = cols[len(cols) // 2 - 6:len(cols) // 2 + 6]
    assert len(cols) == 12
    bottom = int(np.nonzero(red[:, cols[0]])[0].max())       # rows top first
    profile = img[:, cols].mean(axis=1)
    grad = np.abs(np.diff(profile))
    dist = float(np.median(d.reshape(360, 640)[bottom, cols]))
    sigma = 16.0 * 360 / 720 * (1 - np.exp(-density * dist))
    assert sigma > 3.0
    lo, hi = int(bottom - 3 * sigma), int(bottom + 3 * sigma)
    g = grad[lo:hi]
    assert float(g.max()) > 2.0                              # a real edge, blurred
    steep = g > 0.2 * g.max()
    runs = int(steep[0]) + int(np.count_nonzero(steep[1:] & ~steep[:-1]))
    assert runs == 1


def supersampled_ground(still):
    """Per pixel (bottom row first, raveled): the mean of 4x4 sub-pixel rays' exact T
    (float64 reference, rays cast by hand against the calibration scene), whether all of
    them meet the ground, and their mean distance."""
    eye = np.asarray(still.camera.position, dtype=np.float64)
    h, w_ = still.height, still.width
    py, px = np.mgrid[0:h, 0:w_]
    acc = np.zeros(h * w_)
    ground = np.ones(h * w_, bool)
    dist = np.zeros(h * w_)
    for sy in range(4):
        for sx in range(4):
            w = hand_rays(still.camera, px.ravel() + (sx + 0.5) / 4 - 0.5, py.ravel() + (sy + 0.5) / 4 - 0.5,
                          w_, h)
            d, obj = cast(eye, w)
            ground &= obj == 0
            d = np.where(obj == 0, d, 1.0)
            acc += reference(still.fog(), np.broadcast_to(eye, w.shape), w, d, still.time)
            dist += d / 16
    return acc / 16, ground, dist


def test_distant_noise_is_filtered_toward_the_supersampled_picture(renderer):
    """A fine noise (4 m tiles) on the calibration ground, surface mode: each fog texel's T
    against the mean of 4x4 sub-pixel rays' exact T (float64 reference, rays cast by hand
    to the ground plane). Unfiltered, a texel 100-400 m out took one point of noise that
    varies many times within it: RMS 0.075 against the supersampled mean (0.017 at
    20-50 m). Filtered by the mip level its footprint spans: 0.036 and 0.011; with the
    footprint stretched along the view on grazing ground (the geometric mean of its axes):
    0.026 and 0.012, held to at most 0.03 and 0.015."""
    look = dict(scene="calibration", width=320, height=180, time=0.0,
                camera={"position": (0.0, 6.0, 0.0), "yaw": 0.0, "pitch": -8.0, "fov": 60.0},
                effects={"scatter": 0.0, "sky_distance": 400.0},
                layers=[{"kind": "noise", "mode": "surface", "density": 0.01, "scale": 4.0,
                         "height_falloff": False}])
    still = StillParams.model_validate(look)
    from fogbank.render.probes import fog_only
    _, T, _, _ = fog_only(renderer, still)          # bottom row first
    want, ground, dist = supersampled_ground(still)
    got = T.ravel().astype(np.float64)
    for lo, hi, bound in ((20.0, 50.0, 0.015), (100.0, 400.0, 0.03)):
        band = ground & (dist > lo) & (dist < hi)
        assert int(band.sum()) > 500
        assert float(np.sqrt(np.mean((got - want)[band] ** 2))) <= bound


# The 4x MSAA sample positions, in eighths of a pixel from its bottom-left corner: the
# standard pattern (D3D's, used by Mesa and the common GPUs). The fog-free half of the
# test below checks it: with another pattern the hand coverage would not match.
MSAA_POSITIONS = ((3, 1), (7, 3), (1, 5), (5, 7))


@pytest.mark.parametrize("density", [0.0, 0.03])
def test_silhouettes_match_the_per_sample_fog_of_a_hand_raster(renderer, density):
    """Along every silhouette the frame equals the mean over the pixel's four MSAA samples
    of each sample's own blend, T_s c_s + (1 - T_s) f, with the samples' rays cast by hand
    against the calibration scene and T_s from the float64 reference at each sample's own
    distance. A single T per pixel (the averaged inverse distance a blit resolve gives)
    fogged the far surface with the near one's fog: at density 0.03, 62 of the 481 edge
    pixels were off by more than 3 levels (p99 7.0, an outline); with the two-surface
    resolve none is (p99 1.1, max 1.6). Without fog the same check holds the sample
    pattern and the coverage themselves (p99 1.0)."""
    # a camera off the calibration one's round numbers, which put box edges exactly on
    # sample positions (where the rasteriser's tie rule, not the geometry, decides)
    still = calibration_still(layers=[{"kind": "homogeneous", "density": density}],
                              camera={"position": (0.3, 6.1, 0.0), "yaw": 2.0, "pitch": -6.3, "fov": 60.0},
                              effects={"scatter": 0.0, "sky_distance": 400.0, "fog_scale": 1,
                                       "blur": "off"})
    img = renderer.render(still).astype(np.float64)
    view = cam.view(still.camera, W, H)
    py, px = np.mgrid[0:H, 0:W]
    gl_y = (H - 1 - py).ravel()
    albedo = {-1: scenes.CALIBRATION_SKY, 0: scenes.CALIBRATION_GROUND}
    albedo.update({i: c for i, (_, _, c) in enumerate(scenes.CALIBRATION_BOXES, start=1)})
    lin = {k: np.array(srgb_to_linear(c)) for k, c in albedo.items()}
    fog_lin = np.array(srgb_to_linear(still.fog_color))
    acc = np.zeros((H * W, 3))
    objs = []
    for sx, sy in MSAA_POSITIONS:
        w = hand_rays(still.camera, px.ravel() + sx / 8 - 0.5, gl_y + sy / 8 - 0.5, W, H)
        d, obj = cast(view.eye, w)
        obj = np.where(d < cam.FAR, obj, -1)
        d = np.where(obj == -1, still.effects.sky_distance, d)
        T = reference(still.fog(), np.broadcast_to(view.eye, w.shape), w, d, still.time)[:, None]
        c = np.array([lin[o] for o in obj])
        acc += (T * c + (1 - T) * fog_lin) / 4
        objs.append(obj)
    objs = np.array(objs)
    edge = (objs != objs[0]).any(axis=0)            # the samples see more than one object
    edge = edge.reshape(H, W)
    edge[[0, -1], :] = edge[:, [0, -1]] = False
    want = _to_srgb(acc).reshape(H, W, 3)
    err = np.abs(img - want)[edge].max(axis=1)
    assert int(edge.sum()) > 400                   # boxes on ground and sky, the horizon
    assert float(np.quantile(err, 0.99)) <= 2.5
    # a sample within float rounding of an edge may fall either side (1 pixel here)
    assert int(np.count_nonzero(err > 3)) <= 2


def ign(x, y):
    """Interleaved gradient noise (Jimenez 2014) of whole pixel coordinates, in float32 as
    the GPU evaluates it."""
    f32 = np.float32
    d = f32(x) * f32(0.06711056) + f32(y) * f32(0.00583715)
    return np.mod(f32(52.9829189) * np.mod(d, f32(1.0)), f32(1.0)).astype(np.float64)


def test_volume_noise_points_are_jittered_per_pixel_within_the_stated_bound(renderer):
    """A volume noise whose sample cap binds (4 points over 30-700 m): each fog texel's T
    equals the float64 quadrature with the points at the share j of their intervals, j the
    texel's own interleaved gradient noise (at pixel + (7, 13)), written here in numpy.
    (Rays past 700 m are left out: there the frame filters the noise by its footprint,
    tests/gl/test_renderer.py::test_distant_noise_is_filtered_toward_the_supersampled_picture.)
    The midpoint rule (j = 0.5 everywhere, as before) misses by far more; and the picture
    is deterministic. The sample count keeps the stated bound for any j
    (kinds/noise.glsl): tested on the float64 reference in tests/unit/test_reference.py."""
    from fogbank.kinds import noise as noise_kind
    from fogbank.kinds.reference import _env, noise_tex
    from fogbank.render.probes import fog_only
    still = calibration_still(layers=[{"kind": "noise", "mode": "volume", "density": 0.02,
                                       "scale": 300.0, "samples": 4}],
                              effects={"scatter": 0.0, "sky_distance": 400.0, "fog_scale": 1})
    _, T, invd, view = fog_only(renderer, still)            # bottom row first
    _, T2, _, _ = fog_only(renderer, still)
    assert np.array_equal(T, T2)
    h, w_ = T.shape
    gy, gx = np.mgrid[0:h, 0:w_]
    d = np.where(invd > 0, 1.0 / np.maximum(invd, 1e-30), 400.0).ravel().astype(np.float64)
    rays = hand_rays(still.camera, gx.ravel(), gy.ravel(), w_, h)
    fog = still.fog()
    layer = fog.layers[0]
    env = _env(fog, fog.density, noise_tex(fog))
    eye = np.broadcast_to(view.eye, rays.shape)
    t = np.zeros(len(d))
    j = ign(gx.ravel() + 7, gy.ravel() + 13)
    want = np.exp(-noise_kind.optical_depth(layer, eye, rays, d, t, env, jitter=j))
    mid = np.exp(-noise_kind.optical_depth(layer, eye, rays, d, t, env))
    got = T.ravel().astype(np.float64)
    # within 700 m every point samples the exact trilinear noise (one noise texel is 4.7 m;
    # a fog texel spans 0.0064 rad, 4.5 m at 700 m)
    near = d <= 700.0
    capped = noise_kind.volume_samples(layer, env.tex, rays, d, env.weight, j) == layer.samples
    assert near.mean() > 0.8 and capped[near].mean() > 0.9   # the cap binds: the jitter shows
    err = np.abs(got - want)[near]
    assert float(err.max()) <= 1e-4
    assert float(np.sqrt(np.mean((got - mid)[near] ** 2))) >= 10 * float(np.sqrt(np.mean(err ** 2)))
    # The frame's filter (3x3 depth-aware mean of the fog texels, passes/fog_filter.frag)
    # turns the jitter into a stratified estimate: against the same noise with 128 points
    # (float64), RMS 0.00092 where the midpoint rule's 4 points err by 0.0023 (bound: 1/2;
    # in the countryside at 60 m per tile and 6 points, 0.0044 against 0.023).
    _, Tf, _, _ = fog_only(renderer, still, filtered=True)
    fine = layer.model_copy(update={"samples": 128})
    ref = np.exp(-noise_kind.optical_depth(fine, eye, rays, d, t, env))
    rms_filtered = float(np.sqrt(np.mean((Tf.ravel().astype(np.float64) - ref)[near] ** 2)))
    rms_midpoint = float(np.sqrt(np.mean((mid - ref)[near] ** 2)))
    assert rms_filtered <= rms_midpoint / 2



def test_fine_cosine_waves_do_not_alias_into_stripes(renderer):
    """Cosine layers and stripes: the stripes seen in biri-fig6 at 8 m per function unit
    were its layers (the 5 pi y term repeats every 3.2 m, so tree crowns and slopes cross
    several), not aliasing; at 150 m per unit (tests/gl/test_presets.py) they are the
    paper's broad layers. Aliasing itself stays small, because the closed form's part that
    varies with the ray's end, c sin(k . P) / (k . w), shrinks as the waves get finer: a
    cosine layer of 5.5 m waves (tilted) on the calibration ground, each fog texel's T
    against the mean of 4x4 sub-pixel rays' exact T (float64 reference, rays cast by hand
    to the ground plane), is within RMS 0.00014 at 20-60 m and 0.0012 at 60-400 m (bound
    0.002, half an 8-bit level; the pixel-centre ray's own float64 T is as far)."""
    look = dict(scene="calibration", width=320, height=180, time=0.0,
                camera={"position": (0.0, 6.0, 0.0), "yaw": 0.0, "pitch": -8.0, "fov": 60.0},
                effects={"scatter": 0.0, "sky_distance": 400.0},
                layers=[{"kind": "cosine", "density": 0.02, "c0": 1.0, "scale": 2.0,
                         "terms": [{"amp": 0.95, "k": (1.0, 2.0, 0.5), "phase": 0.3}]}])
    still = StillParams.model_validate(look)
    from fogbank.render.probes import fog_only
    _, T, _, _ = fog_only(renderer, still)          # bottom row first
    want, ground, dist = supersampled_ground(still)
    got = T.ravel().astype(np.float64)
    assert float(np.ptp(want[ground])) > 0.3     # the fog varies: the check has teeth
    for lo, hi in ((20.0, 60.0), (60.0, 400.0)):
        band = ground & (dist > lo) & (dist < hi)
        assert int(band.sum()) > 1000
        assert float(np.sqrt(np.mean((got - want)[band] ** 2))) <= 0.002


def test_the_frame_just_drawn_counts_against_the_whole_cache_budget(renderer):
    """Scene passes of 6 slots at 1280x720 and then one at 1920x1080, in a 128 MB cache:
    after each frame the caches hold at most the budget or that frame's own targets and
    scene pass, whichever is more. Before, each half of the budget could keep its share of
    the frame on top of a full half of other entries."""
    from fogbank.render.renderer import Renderer
    r = Renderer(renderer.ctx, cache_bytes=128 << 20)
    base = StillParams(width=1280, height=720, effects={"sun_through_fog": True})
    sizes = [(1280, 720)] * 6 + [(1920, 1080)]
    for i, (w, h) in enumerate(sizes):
        still = base.model_copy(update={"width": w, "height": h,
                                        "camera": base.camera.model_copy(update={"yaw": float(i)})})
        r.render(still, slot=f"s{i}")
        own = r.caches.targets(w, h).nbytes() + r.caches.gbuffer(f"s{i}", w, h, True).nbytes()
        assert r.cache_bytes() <= max(128 << 20, own)
    assert r.cache_bytes() > 128 << 20        # the 1080p frame alone is over the budget: it is kept
    # its session ends: nothing keeps that frame, and the caches are held to budget again
    # (the worker of a closed 1080p session held ~300 MB until its next frame)
    r.drop_slot(f"s{len(sizes) - 1}")
    assert r.cache_bytes() <= 128 << 20
    r.release_caches()
