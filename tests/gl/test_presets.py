"""Each seed preset shows what its figure shows, held by a measurable criterion on the
rendered fog (raw T per fog texel from the frame's own passes) or on rays through the
renderer, against what the paper says of the figure."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.model.params import FogParams, StillParams
from fogbank.model.presets import preset_dict, presets
from fogbank.render.probes import fog_only

PRESET_NAMES = sorted(presets())


def preset_still(name, **over):
    return StillParams.model_validate({**preset_dict(name), "width": 160, "height": 90, **over})


@pytest.mark.parametrize("name", ["biri-fig6", "biri-fig7", "biri-fig8"])
def test_biri_presets_fill_points_beyond_the_threshold_with_fog(renderer, name):
    """Biri 4.2: "if depth is beyond a viewing threshold ... the transparency will be set
    to 1 to represent the fog color". Every fog texel farther than the preset's cutoff
    (the sky among them) has raw T = 0, and they are a real share of the view (before,
    the cutoff cleared them: an unfogged sky above dense ground fog)."""
    still = preset_still(name)
    e = still.effects
    assert (e.cutoff_mode, e.cutoff_distance > 0) == ("fog", True)
    _, T, invd, _ = fog_only(renderer, still)
    d = np.where(invd > 0, 1.0 / np.maximum(invd, 1e-30), e.sky_distance)
    beyond = d > e.cutoff_distance
    assert beyond.mean() > 0.1
    assert float(T[beyond].max()) == 0.0
    assert float(T[~beyond].min()) > 0.0   # nearer points keep their integrated fog


def test_perlin_fog_has_no_threshold_and_fogs_its_sky(renderer):
    """The Perlin write-up has no viewing threshold: its preset has none, so its sky is
    fogged like any far point (before, a cutoff of 600 m left it clear)."""
    still = preset_still("perlin-fog")
    assert still.effects.cutoff_distance == 0.0
    _, T, invd, _ = fog_only(renderer, still)
    assert float(np.median(T[invd == 0])) < 0.5   # before: 1.0 for every sky texel


def test_fischer_smoke_is_temporally_stable(renderer):
    """Frames 0.1 s apart over 8 s of the chimney smoke: no texel's fog transmittance
    changes by more than motion can change it, and the total fog amount by at most 4% of
    its mean (6.7% before). Motion: a particle's opacity falls off at alpha / R per metre
    from its centre, and it moves at most v = 3 m/s (its launch speed, or the wind that
    its drag pulls it to), so in 0.1 s a texel's T changes by at most alpha v 0.1 / R:
    0.44 for the smoke's newborn particles (0.8, 0.55 m; 0.35 seen, just over the
    chimney). Particles born at full strength popped in by 0.80; when the smoke's
    particles were born 2 m wide the bound was 0.2."""
    base = preset_dict("fischer-smoke")
    layer = base["layers"][0]
    v = max(layer["speed"], base["wind"]["speed"])
    Ts = []
    for i in range(80):
        still = StillParams.model_validate({**base, "width": 240, "height": 135, "time": base["time"] + 0.1 * i})
        Ts.append(fog_only(renderer, still)[1].astype(np.float64))
    Ts = np.array(Ts)
    bound = layer["alpha"] * v * 0.1 / layer["radius"]
    assert bound < 0.5   # well under a pop's 0.80
    assert float(np.abs(np.diff(Ts, axis=0)).max()) <= bound
    amount = (1.0 - Ts).sum(axis=(1, 2))
    assert float(np.abs(np.diff(amount)).max() / amount.mean()) <= 0.04
    assert float(amount.min()) > 0.0   # smoke in view all along


def test_biri_fig7_has_no_seam_at_its_tile_borders_and_clears_the_house(renderer):
    """Biri 3.2.2: a tiled polynomial needs "the same value in the border". The figure's
    {0.8, -1, 0, 0, 1} has P(-1) = 2.8 and P(1) = 0.8, so its repeated tiles jumped by 2.0
    (0.028/m of density) at every border, a seam in the picture. Mirrored, 1 m vertical
    rays 5 cm either side of each border near the house see the same fog (|dT| <= 1e-3;
    repeated, they differed by 0.027). And the figure's point stays: "we can see the
    middle of the house but ... the house extremities are surrounded by the mist": 1 m of
    fog at the house's middle is at most 0.8 of that at its ends, 5 m to either side."""
    from fogbank.scene.landmarks import landmarks
    still = preset_still("biri-fig7")
    fog = FogParams.model_validate(still.model_dump(exclude={"width", "height"}))
    hx, hy, hz = landmarks().house
    O = []
    for layer in fog.layers:
        a = np.asarray(layer.axis)
        k = int(np.argmax(np.abs(a)))
        C = layer.half_width
        for border_u in (-3 * C, -C, C, 3 * C):
            x = (border_u - layer.offset) / a[k]       # the border's world coordinate
            for side in (-0.05, 0.05):
                for y in (2.0, 6.0, 12.0):
                    o = np.array([hx, hy + y, hz])
                    o[k] = x + side
                    O.append(o)
    O += [[hx + dx, hy + 2.0, hz] for dx in (0.0, -5.0, 5.0)]
    up = np.tile([0.0, 1.0, 0.0], (len(O), 1))
    T = renderer.transmittance(fog, np.array(O), up, np.ones(len(O)), np.full(len(O), fog.time))
    pairs = T[:-3].reshape(-1, 2, 3)
    assert float(np.abs(pairs[:, 0] - pairs[:, 1]).max()) <= 1e-3
    tau = -np.log(T[-3:])
    assert float(tau[0]) <= 0.8 * float(tau[1:].min())


def test_biri_fig6_shows_layers_not_a_uniform_haze(renderer):
    """Biri: "complex and realistic layers of mist". At 20 m per function unit the 8 m
    vertical period averaged out along every ray: the fog differed from homogeneous fog of
    the same mean density (c0 times the weight) by 0.010 of T on average over the view.
    The layers must show: a mean |dT| of at least 0.08 against that homogeneous fog
    (0.14 at 150 m per unit, where the vertical period is 60 m)."""
    still = preset_still("biri-fig6", width=320, height=180)
    layer = still.layers[0]
    _, T, _, _ = fog_only(renderer, still)
    flat = still.model_copy(update={"layers": [
        StillParams.model_validate({"layers": [{"kind": "homogeneous", "density": layer.density * layer.c0}]}).layers[0]]})
    _, Th, _, _ = fog_only(renderer, flat)
    seen = (T > 0) & (Th > 0)           # not beyond the threshold, where both are fog colour
    assert seen.mean() > 0.5
    assert float(np.abs(T - Th)[seen].mean()) >= 0.08


def test_fischer_fog_is_ground_fog_along_the_river_from_hundreds_of_particles(renderer):
    """Fischer's fog is many faint particles. The preset was one opaque blob at the bridge
    (181 particles from one point within 8 m: min T 0.0002, fog on 0.8% of the view).
    Now: at least 200 particles alive, 90% of them within 35 m of the river's centre line
    and 6 m of the ground, spread over at least 120 m along it; nowhere opaque (min T
    >= 0.2) and fog (T < 0.9) on at least 10% of the view."""
    from fogbank.kinds.particles import simulate_state
    from fogbank.scene import terrain
    still = preset_still("fischer-fog", width=320, height=180)
    pos, *_ = simulate_state(still.layers[0], still.time, still)
    assert len(pos) >= 200
    off = np.abs(pos[:, 0] - terrain.river_x(pos[:, 2]))
    above = pos[:, 1] - terrain.height(pos[:, 0], pos[:, 2])
    assert (float(np.percentile(off, 90)) <= 35.0, float(np.percentile(above, 90)) <= 6.0) == (True, True)
    assert float(np.ptp(pos[:, 2])) >= 120.0
    _, T, _, _ = fog_only(renderer, still)
    assert float(T.min()) >= 0.2
    assert float((T < 0.9).mean()) >= 0.10


def test_biri_fig8_mist_gathers_on_the_trees(renderer):
    """Biri: "Four point equipotential functions ... centered in the trees ... fog seems to
    concentrate on the trees". The optical depth from the eye to 2 m above each tree is at
    least 1.5 times the mean of the same at points 20 m to either side across the view,
    for at least 3 of the 4 trees (1.82, 1.19, 1.58, 1.85; before, with wide potentials
    over denser constant fog, 1.23, 1.06, 1.20, 1.30: a haze, not mist on the trees)."""
    from fogbank.scene.landmarks import landmarks
    fog = FogParams.model_validate(preset_dict("biri-fig8"))
    eye = np.array(fog.camera.position)
    O, W, D = [], [], []
    for tree in landmarks().trees:
        top = np.array(tree) + [0.0, 2.0, 0.0]
        side = np.cross(top - eye, [0.0, 1.0, 0.0])
        side /= np.linalg.norm(side)
        for off in (0.0, -20.0, 20.0):
            q = top + side * off - eye
            O.append(eye)
            W.append(q / np.linalg.norm(q))
            D.append(np.linalg.norm(q))
    T = renderer.transmittance(fog, np.array(O), np.array(W), np.array(D), np.full(len(D), fog.time))
    tau = -np.log(T.reshape(-1, 3).astype(np.float64))
    ratio = tau[:, 0] / tau[:, 1:].mean(axis=1)
    assert int((ratio >= 1.5).sum()) >= 3


def ray_elevations(camera, width, height):
    """Each pixel's ray elevation above the horizon (degrees; rows bottom first), written
    from the camera convention (pitch about the camera's x, vertical fov), not scene/camera."""
    tan = np.tan(np.radians(camera.fov) / 2)
    nx = (np.arange(width) + 0.5) / width * 2 - 1
    ny = (np.arange(height) + 0.5) / height * 2 - 1
    NX, NY = np.meshgrid(nx * tan * width / height, ny * tan)
    p = np.radians(camera.pitch)
    y = NY * np.cos(p) + np.sin(p)
    back = NY * np.sin(p) - np.cos(p)
    return np.degrees(np.arctan2(y, np.hypot(NX, back)))


@pytest.mark.parametrize("name", ["perlin-fog", "quilez-spheres", "default"])
def test_the_land_reaches_the_horizon(renderer, name):
    """The terrain ended at +-220 m, and its edge showed at the horizon as a ridge and a flat
    band of sky below it. A far skirt of the same height field runs to 3.5 km: every
    pixel whose ray points 1 degree or more below the horizon meets the land (1/distance
    > 0), none of them the sky."""
    still = preset_still(name, width=320, height=180)
    _, _, invd, _ = fog_only(renderer, still)
    below = ray_elevations(still.camera, invd.shape[1], invd.shape[0]) <= -1.0   # per fog texel
    assert below.mean() > 0.3
    assert int((invd[below] <= 0).sum()) == 0


# ------------------------------------------------------------------ the pictures (issue 32)
# Each figure's caption, and each finding of the artist's table, as a number on the frame.


def render(renderer, name, w=480, **over):
    """The preset's frame as float64 sRGB levels (rows top first), and its still."""
    from fogbank.model.presets import merge
    still = StillParams.model_validate(merge({**preset_dict(name), "width": w, "height": w * 9 // 16}, over))
    return renderer.render(still).astype(np.float64), still


def angles_to(still, direction):
    """Each pixel's angle (degrees, rows top first) to a direction, from the hand-written camera."""
    from hand import hand_rays
    h, w = still.height, still.width
    py, px = np.mgrid[0:h, 0:w]
    rays = hand_rays(still.camera, px.ravel(), (h - 1 - py).ravel(), w, h)
    return np.degrees(np.arccos(np.clip(rays @ np.asarray(direction), -1, 1))).reshape(h, w)


def pixels_of(camera, w, h, points):
    """Where world points (N, 3) fall in a w x h frame: (column, row counted from the
    bottom, as the fog target's rows), floats, by the camera's view-projection and the
    perspective divide written out here."""
    from fogbank.scene import camera as cam
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    c = np.c_[p, np.ones(len(p))] @ cam.view(camera, w, h).view_proj.T
    return (c[:, 0] / c[:, 3] * 0.5 + 0.5) * w, (c[:, 1] / c[:, 3] * 0.5 + 0.5) * h


@pytest.mark.parametrize("name", ["default", "gawron-distance", "shaded-valley", "forest-shafts"])
def test_the_sun_is_no_clipped_patch(renderer, name):
    """The default look's sun was a flat clipped patch: 3.2% of the frame at 255 (a 190 x
    210 px area at 1280x720), red clipped over ~500 px, a colour shift at its edge; a fresh
    eye found gawron-distance's scatter a clipped peach disc (130k pixels of 921k with a
    channel at 250 or more). Tone mapped (Khronos PBR Neutral), no pixel farther than 2
    degrees from the sun's centre (its disc is ~0.8 degrees) has a channel at 254 or
    more, and where the sun is in view its glow is rolled off, not cut: brighter near the
    sun than 30 degrees away."""
    img, still = render(renderer, name)
    ang = angles_to(still, still.sun.direction())
    far = ang > 2.0
    assert far.mean() > 0.95
    print(f"\n{name}: {float((img.max(axis=2) >= 254)[far].mean()):.4f} of the frame clipped off the sun")
    assert float((img.max(axis=2) >= 254)[far].mean()) == 0.0
    # nor a plateau just under the clip: a fresh eye saw gawron-distance's scatter as a flat
    # peach column (a sixth of the frame at 245-253), shaded-valley's sunlit fog as a
    # near-clipped peach band (4%) and forest-shafts' glow as a cream plateau (6%); at most
    # 2% of the frame at 245 or more
    print(f"{name}: {float((img.max(axis=2) >= 245)[far].mean()):.4f} of the frame at 245 or more off the sun")
    assert float((img.max(axis=2) >= 245)[far].mean()) <= 0.02
    # the glow is there, rolled off: brighter near the sun than 30 degrees away
    if ((ang > 2.0) & (ang < 6.0)).sum() > 100:
        assert float(img[(ang > 2.0) & (ang < 6.0)].mean()) >= float(img[(ang > 28.0) & (ang < 32.0)].mean()) + 10.0


def test_biri_fig7_the_house_is_clear_in_the_middle_misty_at_its_ends_and_the_waves_move(renderer):
    """Fig. 7: "we can see the middle of the house but ... the house extremities are
    surrounded by the mist"; Fig. 5: the density moves with the wind. The fog texels' T
    at the front wall's middle is above T at either end (4.3 m out) by 0.08, one of them
    by 0.2 (the figure's quartic rises to 2.8 on one side, 0.8 at its mirrored border on
    the other; every ray crosses fog from the eye's side too; measured 0.480 against 0.210
    and 0.376, where the look a fresh eye found evenly veiled gave 0.233 against 0.190 and
    0.163), and
    4 s later the fog elsewhere has moved (mean |dT| >= 0.005) while the middle stays clear."""
    from fogbank.scene.landmarks import landmarks
    hx, hy, hz = landmarks().house
    still = preset_still("biri-fig7", width=320, height=180)

    def t_at(T, points):
        x, y = pixels_of(still.camera, T.shape[1], T.shape[0], points)
        return T[y.astype(int), x.astype(int)].astype(np.float64)
    wall = [(hx + dx, hy + 2.5, hz + 3.62) for dx in (0.0, -4.3, 4.3)]
    _, T0, _, _ = fog_only(renderer, still)
    mid, left, right = t_at(T0, wall)
    print(f"\nthe wall's T: middle {mid:.3f}, ends {left:.3f} and {right:.3f}")
    assert mid >= max(left, right) + 0.08 and mid >= min(left, right) + 0.2
    _, T4, _, _ = fog_only(renderer, still.model_copy(update={"time": still.time + 4.0}))
    print(f"mean |dT| over 4 s {float(np.abs(T4 - T0).mean()):.4f}")
    assert float(np.abs(T4 - T0).mean()) >= 0.005
    assert abs(t_at(T4, wall[:1])[0] - mid) <= 0.03


def test_fischer_smoke_leaves_the_chimney(renderer):
    """A fresh eye saw the smoke as a tube detached from the chimney: born 0.4 m above its
    top, a particle fades in over its first 2 steps (1.4 m), so the first metre and a half
    over the chimney was clear (T 0.6-0.7 just over its top). The fog texels from 5 cm to
    1 m above the chimney's top, by a hand-written projection of those points, hold smoke
    (T < 0.5) at every second from 12 to 16 s."""
    from fogbank.model.presets import _house_chimney
    cx, cy, cz = _house_chimney()
    still = preset_still("fischer-smoke", width=320, height=180)
    # the chimney's top is cy + 0.4 (scene/meshes.py _house)
    x, y = pixels_of(still.camera, 320, 180, [(cx, cy + up, cz) for up in (0.45, 0.9, 1.4)])
    for t in (12.0, 13.0, 14.0, 15.0, 16.0):
        _, T, _, _ = fog_only(renderer, still.model_copy(update={"time": t}))
        ts = T[y.astype(int), x.astype(int)].astype(np.float64)
        print(f"\nt {t}: T above the chimney {np.round(ts, 3)}")
        assert max(ts) < 0.5


def test_fischer_smoke_rises_spreads_and_moves(renderer):
    """The smoke read as a faint frozen ribbon of steam (its mean changed by 0.02 levels from
    t = 12 to 20 s). Its plume (fog texels with T < 0.9) covers at least 0.5% of the view,
    is dark where thick (its in-scattered share of the sunlight is below half where T <
    0.5: it shades itself), and moves: a second later its T changes by 0.03 on average over
    the plume (the frozen ribbon: 1e-4). A later fresh eye saw a tube of nearly constant
    width: it spreads, its rows' width (texels with T < 0.9) over its top fifth at least 1.4
    times that over its bottom fifth, at both times (the tube: 1.17; now 1.8-2.2)."""
    still = preset_still("fischer-smoke", width=320, height=180)
    _, T0, _, _ = fog_only(renderer, still)
    _, T1, _, _ = fog_only(renderer, still.model_copy(update={"time": still.time + 1.0}))
    a, b = T0 < 0.9, T1 < 0.9
    assert a.mean() >= 0.005 and b.mean() >= 0.005
    assert float(np.abs(T1 - T0)[a | b].mean()) >= 0.03
    for m in (a, b):
        widths = m[m.any(axis=1)].sum(axis=1)   # rows bottom first
        n = max(1, len(widths) // 5)
        spread = float(np.median(widths[-n:])) / float(np.median(widths[:n]))
        print(f"\nthe plume's top fifth over its base: {spread:.2f} times as wide")
        assert spread >= 1.4
    from fogbank.render.probes import fog_target
    f = fog_target(renderer, still)
    thick = f[..., 0] < 0.5
    assert thick.sum() > 20
    share = f[..., 3][thick] / np.maximum(1.0 - f[..., 0][thick], 1e-6)
    assert float(np.median(share)) < 0.5


def test_fischer_smoke_reads_as_smoke_from_a_chimney(renderer):
    """A fresh eye rejected the smoke: steam (brighter than the sky behind it), no chimney
    (the smoke's first puff hid it), a 90 px blob over the roof, rising straight out of the
    frame. At 320x180, at 12, 14 and 16 s (fog texels, rows bottom first; the chimney and
    its faces by a hand-written projection):
    - the chimney shows: over its two faces toward the camera, 0.3-0.5 m under its top,
      the median T is at least 0.6 (the old smoke: 0.00-0.01);
    - the plume starts thin: its base rows (texels with T < 0.9, the lowest fifth) are at
      most 4 times as wide as the chimney (the old: 6 times, 22-25 px);
    - it bends over in the wind and stays in view: from its base to its top fifth its
      middle moves sideways by at least half its height (the old: 0.29-0.33, now 0.8-0.9),
      and no plume texel lies on the frame's top row or side columns (the old left at the top);
    - it is smoke, not steam: where thick (T < 0.5) over the sky, its median level is at
      least 20 under the clear sky's (the old: 9 over it; now 40 under)."""
    from fogbank.model.presets import _house_chimney
    from fogbank.scene.landmarks import landmarks
    cx, cy, cz = _house_chimney()
    hx, _, hz = landmarks().house
    W, H = 320, 180
    still = preset_still("fischer-smoke", width=W, height=H)
    # the chimney: x in [hx + 2.2, hx + 3.1], z in [hz - 1.2, hz - 0.3], its top cy + 0.4
    # (scene/meshes.py _house); the camera, west and south of it, sees its x- and z+ faces
    face = ([(hx + 2.2, y, z) for z in np.linspace(hz - 1.1, hz - 0.4, 5) for y in (cy - 0.1, cy + 0.1)]
            + [(x, y, hz - 0.3) for x in np.linspace(hx + 2.3, hx + 3.0, 5) for y in (cy - 0.1, cy + 0.1)])
    fx, fy = pixels_of(still.camera, W, H, face)
    ex, _ = pixels_of(still.camera, W, H, [(hx + 2.2, cy, hz - 0.3), (hx + 3.1, cy, hz - 0.3),
                                           (hx + 2.2, cy, hz - 1.2), (hx + 3.1, cy, hz - 1.2)])
    chimney_px = float(ex.max() - ex.min())
    for t in (12.0, 14.0, 16.0):
        s = still.model_copy(update={"time": t})
        _, T, invd, _ = fog_only(renderer, s)
        T = T.astype(np.float64)
        chimney = float(np.median(T[fy.astype(int), fx.astype(int)]))
        m = T < 0.9
        rows = np.flatnonzero(m.any(axis=1))
        n = max(1, len(rows) // 5)
        widths = m[rows].sum(axis=1)
        middle = (m[rows] * np.arange(W)).sum(axis=1) / widths
        bend = (np.median(middle[-n:]) - np.median(middle[:n])) / (rows[-1] - rows[0])
        base = float(np.median(widths[:n]))
        img = renderer.render(s).astype(np.float64)[::-1].mean(axis=2)   # rows bottom first
        sky = invd == 0
        plume, clear = float(np.median(img[(T < 0.5) & sky])), float(np.median(img[(T > 0.99) & sky]))
        print(f"\nt {t}: chimney T {chimney:.2f}, base {base:.0f} px (chimney {chimney_px:.1f}), bend {bend:.2f}, "
              f"plume level {plume:.0f} against the sky's {clear:.0f}")
        assert chimney >= 0.6
        assert base <= 4.0 * chimney_px
        assert abs(bend) >= 0.5
        assert not (m[-1].any() or m[:, 0].any() or m[:, -1].any())
        assert plume <= clear - 20.0


@pytest.mark.parametrize("name,shade,depth", [("fischer-fog", 0.03, 6.0), ("forest-shafts", 0.05, 6.0),
                                              ("shaded-valley", 0.35, 15.0)])
def test_fog_in_shadow_is_darker_than_fog_in_sun(renderer, name, shade, depth):
    """The fog was as bright in shadow as in sun. The same frame without the scene's
    shadows in the fog (effects.shafts 0) against the preset's: on at least `shade` of the
    view the preset's fog is darker by 4 levels or more (the shadows of trees and hills
    through the fog), with a median of at least `depth` levels there, and never lighter
    than rounding (the shadows only take light away). shaded-valley's shade is a large
    region: a fresh eye saw none where 27% of the view was darker by a median of 9 levels
    (the sky lit the shaded fog nearly as brightly as the sun); now half the view, by 17."""
    img, still = render(renderer, name, w=320)
    plain, _ = render(renderer, name, w=320, effects={"shafts": 0.0})
    drop = (plain - img).mean(axis=2)
    dark = drop >= 4.0
    print(f"\n{name}: {float(dark.mean()):.3f} of the view darker, by {float(np.median(drop[dark])):.1f} levels (median)")
    assert float(dark.mean()) >= shade
    assert float(np.median(drop[dark])) >= depth
    assert float(drop.min()) >= -2.0


def test_the_shaded_valleys_sunlit_fog_has_no_column_mottle(renderer):
    """A fresh eye saw shaded-valley's sunlit fog near the ground as a blocky mottle (6-15 px
    cells): the light grid's columns, each catching the trees' long shadows with its own
    jittered shadow taps (4 a slice). Over the frame's lower left (sunlit fog over the
    forest's shadows), the fog's sunlit share J / (1 - T) less its 9-texel box mean is
    0.0036 on average with 4 taps, 0.0029 with 8 ("high" now), 0.0027 with 16: at most
    0.0032."""
    from scipy.ndimage import uniform_filter

    from fogbank.render.probes import fog_target
    still = preset_still("shaded-valley", width=640, height=360)
    a = fog_target(renderer, still)[::-1]   # rows top first
    T, J = a[..., 0].astype(np.float64), a[..., 3].astype(np.float64)
    share = J / np.maximum(1.0 - T, 1e-6)
    h, w = share.shape
    region = share[int(h * 0.58):, : int(w * 0.4)]
    assert float(region.mean()) > 0.2   # sunlit fog, not the shade
    rough = float(np.abs(region - uniform_filter(region, 9)).mean())
    print(f"\nshaded-valley's column-scale roughness {rough:.4f}")
    assert rough <= 0.0032


def test_the_clearing_is_carved_inside_standing_fog(renderer):
    """carved-clearing: the house was pixel-identical to the frame without fog, though
    ~22 m of dense fog lay between it and the eye (the carving took the whole ray's share).
    Now the house's texels keep the fog in front of them (T <= 0.9), and are clearer than
    ground at the same distance beside the clearing: at least 4 times its T, a pocket of
    clear air that shows (seen from 24 m up at the fog's level it was 2.2 times, 0.215
    against 0.096, and a fresh eye saw no clearing; from above the fog, 0.412 against 0.049)."""
    from fogbank.scene.landmarks import landmarks
    hx, hy, hz = landmarks().house
    still = preset_still("carved-clearing", width=320, height=180)
    _, T, invd, _ = fog_only(renderer, still)
    (x,), (y,) = pixels_of(still.camera, T.shape[1], T.shape[0], [(hx, hy + 2.0, hz + 3.7)])
    house = float(T[int(y), int(x)])
    d_house = 1.0 / float(invd[int(y), int(x)])
    assert house <= 0.9
    d = np.where(invd > 0, 1.0 / np.maximum(invd, 1e-30), np.inf)
    same = np.abs(d - d_house) < 3.0
    cols = np.abs(np.arange(T.shape[1])[None, :] - x) > 40   # beside the clearing
    outside = T[same & cols]
    assert len(outside) > 20
    print(f"\nthe house's T {house:.3f}, the ground beside at its distance {float(np.median(outside)):.3f}")
    assert house >= 4.0 * float(np.median(outside))


def test_gawron_scatter_is_orange(renderer):
    """Fig. 3's scatter is orange; the preset's read pink-salmon. Around the sun (within 20
    degrees, off its disc) the frame's hue is between 18 and 45 degrees (orange), with
    saturation."""
    import colorsys
    img, still = render(renderer, "gawron-distance", w=320)
    ang = angles_to(still, still.sun.direction())
    px = img[(ang < 20.0) & (ang > 3.0)] / 255.0
    hsv = np.array([colorsys.rgb_to_hsv(*p) for p in px[::7]])
    assert 18.0 <= float(np.median(hsv[:, 0])) * 360.0 <= 45.0
    assert float(np.median(hsv[:, 1])) >= 0.25


def test_gawron_scatter_stays_near_the_sun(renderer):
    """Fig. 3: "a soft orange scattering from a light source is added to the grey-blue fog".
    The preset's lobe (exponent 4) washed the frame's sun side peach: red stood over blue by
    41 levels (median) from 30 to 40 degrees off the sun. Within 15 degrees of the sun the
    fog is orange (red over blue by 40 levels or more); from 30 to 40 degrees it is the
    grey-blue fog (red at most blue's)."""
    img, still = render(renderer, "gawron-distance", w=320)
    ang = angles_to(still, still.sun.direction())
    rb = img[..., 0].astype(float) - img[..., 2].astype(float)
    near, off = rb[(ang < 15.0) & (ang > 3.0)], rb[(ang > 30.0) & (ang < 40.0)]
    print(f"\nred - blue: near the sun {float(np.median(near)):.1f}, 30-40 degrees off {float(np.median(off)):.1f}")
    assert len(near) > 100 and len(off) > 1000
    assert float(np.median(near)) >= 40.0
    assert float(np.median(off)) <= 0.0


def test_gawron_scatter_is_a_halo_round_the_sun(renderer):
    """Two fresh eyes saw gawron-distance's orange as a vertical pillar from the frame's top
    to the horizon: the sun sat 5 degrees under the top edge, and the glow's upper half was
    cut off (red at the top edge 239 against 246 at the sun). The frame holds the glow above
    the sun too: pixels 12-18 degrees from it and above it (their rays 10 degrees or more
    higher) exist, and there red over blue has fallen 15 levels or more below its median
    within 3-6 degrees of the sun (measured 72 -> 52)."""
    img, still = render(renderer, "gawron-distance", w=320)
    ang = angles_to(still, still.sun.direction())
    elev = ray_elevations(still.camera, still.width, still.height)[::-1]   # rows top first
    rb = img[..., 0] - img[..., 2]
    above = (ang > 12.0) & (ang < 18.0) & (elev > still.sun.elevation + 10.0)
    near = (ang > 3.0) & (ang < 6.0)
    print(f"\nred - blue: near the sun {float(np.median(rb[near])):.1f}, 12-18 degrees above it "
          f"{float(np.median(rb[above])) if above.any() else float('nan'):.1f} ({int(above.sum())} px)")
    assert above.sum() > 50 and near.sum() > 50
    assert float(np.median(rb[above])) <= float(np.median(rb[near])) - 15.0


def test_the_fog_box_has_soft_faces(renderer):
    """fog-volumes: the box read as a frosted-glass slab, its faces hard. Through the
    frame's GLSL (the transmittance API), 2 m of fog 0.2 m inside its top face holds under
    a fifth of 2 m at its middle (with hard faces, as much)."""
    still = preset_still("fog-volumes", width=320, height=180)
    box = [l for l in still.layers if l.kind == "box"][0]
    fog = FogParams.model_validate(still.model_copy(update={"layers": [box]}).model_dump(exclude={"width", "height"}))
    hard = fog.model_copy(update={"layers": [box.model_copy(update={"edge_fade": 0.0})]})
    R = box.axes()
    c = np.asarray(box.center)
    top = c + R[1] * (box.half_size[1] - 0.2)   # 0.2 m under the top face, along the body's y
    O = np.array([top, c]) - R[0] * 1.0
    W = np.tile(R[0], (2, 1))
    for look, ratio in ((fog, (0.0, 0.2)), (hard, (0.99, 1.01))):
        T = renderer.transmittance(look, O, W, np.full(2, 2.0), np.zeros(2)).astype(np.float64)
        tau = -np.log(T)
        assert tau[1] > 0.05 and ratio[0] <= tau[0] / tau[1] <= ratio[1]


def test_the_fog_ellipsoid_has_a_soft_lower_edge(renderer):
    """fog-volumes: a fresh eye saw the forest's ellipsoid as a lens sitting on the canopy,
    its curved lower edge cutting trees in half. Through the frame's GLSL (the
    transmittance API), along a vertical fan of rays from the eye through the ellipsoid's
    centre 0.01 degree apart, its opacity (alone, rays of 1 km) rises from 10% to 90% of
    its peak across the lower edge over at least 2 degrees (24 px at 720p, fov 60): it
    took 0.9 (11 px); now 2.7."""
    still = preset_still("fog-volumes")
    ell = [l for l in still.layers if l.kind == "ellipsoid"][0]
    fog = FogParams.model_validate(still.model_copy(update={"layers": [ell]}).model_dump(exclude={"width", "height"}))
    eye, c = np.asarray(still.camera.position, float), np.asarray(ell.center, float)
    f = (c - eye) / np.linalg.norm(c - eye)
    up = np.array([0.0, 1.0, 0.0]) - f * f[1]
    up /= np.linalg.norm(up)
    ang = np.radians(np.linspace(-6.0, 6.0, 1201))
    W = np.cos(ang)[:, None] * f + np.sin(ang)[:, None] * up
    T = renderer.transmittance(fog, np.tile(eye, (len(ang), 1)), W, np.full(len(ang), 1000.0),
                               np.zeros(len(ang))).astype(np.float64)
    op = 1.0 - T
    peak, k = float(op.max()), int(op.argmax())
    assert peak > 0.5 and 0 < k < len(ang) - 1   # the fan crosses the body
    rise = np.degrees(ang[np.flatnonzero(op[:k + 1] >= 0.9 * peak)[0]] - ang[np.flatnonzero(op[:k + 1] >= 0.1 * peak)[0]])
    print(f"\nthe ellipsoid's lower edge: 10% to 90% over {rise:.2f} degrees")
    assert rise >= 2.0


@pytest.mark.parametrize("name", ["gawron-distance", "shaded-valley"])
def test_no_hard_horizon_line(renderer, name):
    """gawron-distance's distance fog stopped at 75% opacity, so a quarter of the far land's
    green showed under the sky: a hard straight line at the horizon (the mean row level
    stepped 18 levels over 4 px at 640x360); shaded-valley's fog, thinning over 6.7 m, met
    the sky in a razor line (7.8 levels). Within 2 degrees of the horizon no 4 px step of
    the mean row level exceeds 7 levels."""
    img, still = render(renderer, name, w=640)
    lum = img.astype(float).mean(axis=2).mean(axis=1)
    elev = ray_elevations(still.camera, still.width, still.height)[::-1].mean(axis=1)   # rows top first
    rows = np.flatnonzero(np.abs(elev) <= 2.0)
    rows = rows[(rows >= 2) & (rows < len(lum) - 2)]
    assert len(rows) > 10
    assert float(np.abs(lum[rows - 2] - lum[rows + 2]).max()) <= 7.0


@pytest.mark.parametrize("name,most", [("quilez-spheres", 100.0), ("fischer-fog", 110.0)])
def test_the_far_land_pales_into_the_sky(renderer, name, most):
    """A fresh eye saw the clear looks' world edge as a hard, ruler-straight green line
    against the sky: the land within 1.3 degrees below the horizon and the sky within 1.3
    degrees above differed by 159 (quilez-spheres) and 196 (fischer-fog) levels in blue.
    The air's haze (common/sky.glsl atmosphereHaze) pales the far land toward the sky's
    colour there: 78 and 91 now."""
    img, still = render(renderer, name, w=640)
    elev = ray_elevations(still.camera, still.width, still.height)[::-1]   # rows top first
    below, above = (elev < -0.3) & (elev > -1.3), (elev > 0.3) & (elev < 1.3)
    assert below.sum() > 500 and above.sum() > 500
    d = np.abs(img[below].mean(axis=0) - img[above].mean(axis=0))
    print(f"\n{name}: land against sky at the horizon {d.round(1)} levels")
    assert float(d.max()) <= most


@pytest.mark.parametrize("name", ["perlin-fog", "gawron-distance", "default", "biri-fig6"])
def test_no_stripe_at_the_horizon(renderer, name):
    """perlin-fog showed a light stripe at the horizon (+10-16 levels), gawron-distance a
    hard line. The frame's mean level by row, across the rows within 3 degrees of the
    horizon, has no bump: no row is more than 4 levels brighter than both rows 4 px above
    and below it."""
    img, still = render(renderer, name, w=320)
    lum = img.mean(axis=2).mean(axis=1)
    elev = ray_elevations(still.camera, still.width, still.height)[::-1].mean(axis=1)   # rows top first
    rows = np.flatnonzero(np.abs(elev) <= 3.0)
    rows = rows[(rows >= 4) & (rows < len(lum) - 4)]
    assert len(rows) > 3
    bump = lum[rows] - np.maximum(lum[rows - 4], lum[rows + 4])
    assert float(bump.max()) <= 4.0


# shaded-valley's band is not fixed: an eye low enough to take it away (20-25 m, 8.9 -> 1-3
# levels) made the mean row level step 8.4-9.7 levels over 4 px at the horizon
# (test_no_hard_horizon_line, at most 7) or left the frame's sunlit corner in shade
STRIPED = {"shaded-valley": "a fresh eye's bright band at the horizon (8.9 levels), not fixed"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(reason=STRIPED[n], strict=True))
                                  if n in STRIPED else n for n in PRESET_NAMES])
def test_no_bright_band_at_the_horizon(renderer, name):
    """A fresh eye rejected forest-shafts and shaded-valley for a bright band along the
    horizon (test_no_stripe_at_the_horizon's whole rows at 320 px measured forest-shafts'
    0.9: the trees crossing the horizon averaged it away): their thin ground haze lay under the camera's height, so its sunlit
    far top stood between the land and a sky that had none. At 640x360, in each eighth of
    the frame's width and each channel, rows within 3 degrees of the horizon stand at most
    this much over both rows 8 px above and below them, in most eighths (the median: trees
    and the sun's glow cross a few): 8 levels. The clear looks' land, hazed to the sky's
    brightest colour at the horizon, makes the most of the others, 7.3 (fischer-fog);
    forest-shafts measured 11.5 (its eye now inside the haze: 0.4) and shaded-valley 8.9."""
    img, still = render(renderer, name, w=640)
    elev = ray_elevations(still.camera, still.width, still.height)[::-1].mean(axis=1)   # rows top first
    k = 8
    rows = np.flatnonzero(np.abs(elev) <= 3.0)
    rows = rows[(rows >= k) & (rows < img.shape[0] - k)]
    assert len(rows) > 3
    bands = img.reshape(img.shape[0], 8, -1, 3).mean(axis=2)   # rows, eighths, channels
    bump = (bands[rows] - np.maximum(bands[rows - k], bands[rows + k])).max(axis=(0, 2))
    print(f"\n{name}: the horizon's bump by eighth {bump.round(1)}")
    assert float(np.median(bump)) <= 8.0


def test_the_house_terrace_banks_are_grass(renderer):
    """A fresh eye saw grey smudges beside the house in every view of it: the banks of its
    terrace (cut and filled in its slope, up to 46 degrees) took the rock colour, which
    began at 35 degrees. From fischer-fog's camera (its fog off) the ground where it is
    steeper than 40 degrees within 20 m of the house, by a hand-written projection of those
    points into the frame, is green: its median green stands 10 levels over red and over
    blue (measured 25; the rock banks: 4)."""
    from fogbank.scene import terrain
    from fogbank.scene.landmarks import HOUSE
    img, still = render(renderer, "fischer-fog", w=640, layers=[])
    hx, hz = HOUSE
    x, z = np.meshgrid(np.linspace(hx - 20, hx + 20, 81), np.linspace(hz - 20, hz + 20, 81))
    steep = terrain.normal(x, z)[..., 1] < np.cos(np.radians(40.0))
    assert steep.sum() > 50
    p = np.stack([x[steep], terrain.height(x[steep], z[steep]) + 0.05, z[steep]], axis=1)
    u, up = pixels_of(still.camera, still.width, still.height, p)
    u, v = u.astype(int), (still.height - up).astype(int)   # rows top first
    ok = (u >= 0) & (u < still.width) & (v >= 0) & (v < still.height)
    assert ok.sum() > 50
    px = img[v[ok], u[ok]].astype(float)
    green = px[:, 1] - np.maximum(px[:, 0], px[:, 2])
    print(f"\nthe banks' green over red and blue: {float(np.median(green)):.1f} levels ({ok.sum()} points)")
    assert float(np.median(green)) >= 10.0
