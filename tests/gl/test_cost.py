"""The cost estimate: how it scales, what it names, and that its memory matches what the
renderer really allocates for a still."""

from __future__ import annotations

from fogbank.workers import cost
from fogbank.model.params import StillParams


def still(**kw) -> StillParams:
    return StillParams.model_validate({"width": 1280, "height": 720, **kw})


def test_seconds_scale_with_pixels_layers_and_samples():
    base = cost.estimate(still())
    big = cost.estimate(still(width=2560, height=1440))
    assert 3.0 < (big.seconds - cost.SCENE_FIXED_S) / (base.seconds - cost.SCENE_FIXED_S) < 5.0
    v16 = cost.estimate(still(layers=[{"kind": "noise", "mode": "volume", "samples": 16}]))
    v128 = cost.estimate(still(layers=[{"kind": "noise", "mode": "volume", "samples": 128}]))
    p16, p128 = (c.parts["layers[0] (noise, volume, %d samples)" % n] for c, n in ((v16, 16), (v128, 128)))
    assert 6.0 < p128 / p16 < 8.5
    quarter = cost.estimate(still(layers=[{"kind": "noise", "mode": "volume", "samples": 128}],
                                  effects={"fog_scale": 4}))
    assert abs(quarter.parts["layers[0] (noise, volume, 128 samples)"] * 16 - p128) < 1e-9
    assert cost.estimate(still(), scale=0.1).seconds == base.seconds * 0.1


def test_the_biggest_contributors_are_named_first():
    c = cost.estimate(still(layers=[{"kind": "height"}, {"kind": "noise", "mode": "volume", "samples": 128},
                                    {"kind": "particles", "count": 1000, "radius": 10}]))
    top = c.biggest(2)
    assert top[0] == "layers[1] (noise, volume, 128 samples)"
    assert top[1] == "layers[2] (particles, 1000 of radius 10 m)"


def test_disabled_layers_cost_nothing():
    on = cost.estimate(still(layers=[{"kind": "noise", "mode": "volume", "samples": 128}]))
    off = cost.estimate(still(layers=[{"kind": "noise", "mode": "volume", "samples": 128, "enabled": False}]))
    assert off.seconds < on.seconds and not any(k.startswith("layers") for k in off.parts)


def test_memory_estimate_covers_what_the_renderer_allocates(renderer):
    from fogbank.render.renderer import Renderer
    r = Renderer(renderer.ctx, cache_bytes=1 << 40)
    for look in (still(width=640, height=360), still(width=800, height=600, effects={"blur": "separate"}),
                 still(width=512, height=512, effects={"fog_scale": 2})):
        r.release_caches()
        r.render(look)
        allocated = r.cache_bytes()
        est = cost.estimate(look).memory
        assert allocated <= est <= allocated * 1.25, (look.width, allocated, est)
    r.release_caches()


def test_first_draw_compile_is_charged_until_the_worker_has_drawn_the_program():
    """Found by an outside attack: a 16x16 still of 16 volume-noise layers was estimated at
    0.1 s, went to the worker that draws every stream, and held it for 30 s compiling.
    Layers of one kind are now one loop (packing.layer_code): the program, and its
    compile, grow with the distinct kinds, and the estimate says so."""
    tiny = still(width=16, height=16, layers=[{"kind": "noise", "mode": "volume", "samples": 1}] * 16)
    fresh, warm = cost.estimate(tiny), cost.estimate(tiny, compiled=True)
    assert fresh.seconds > warm.seconds
    assert abs(fresh.parts["compiling the fog program for 16 layers (once per worker)"] - (fresh.seconds - warm.seconds)) < 1e-12
    same = [cost.jit_seconds(tuple(("noise", ("volume",)) for _ in range(n))) for n in (2, 4, 8, 16)]
    assert same == [same[0]] * 4
    assert cost.jit_seconds((("noise", ("volume",)),)) < same[0]
    distinct = [cost.jit_seconds(tuple(("cosine", (k,)) for k in range(1, n + 1))) for n in (2, 4, 8)]
    assert distinct == sorted(distinct) and distinct[-1] > same[0]

def test_held_fog_leaves_out_the_layers_that_do_not_move_and_the_shadows():
    """A stream's frame over a still camera, its time-invariant fog and light held by the
    worker (render/passes/fog.py, light.py): the estimate keeps the moving layers (wind,
    drift, particles) toward the eye and the sun, and leaves out the others, the light
    grid's shadow-map samples and their filter."""
    look = still(wind={"speed": 3.0}, effects={"sun_through_fog": True, "shafts": 1.0},
                 layers=[{"kind": "height"}, {"kind": "cosine", "wind": True},
                         {"kind": "noise", "drift": (0.0, 0.0, 1.0)}, {"kind": "potential"},
                         {"kind": "particles", "count": 64}])
    whole = cost.estimate(look, scene_cached=True)
    held = cost.estimate(look, scene_cached=True, fog_held=True)
    layers = lambda c: sorted(k.split(" ")[0] for k in c.parts if k.startswith("layers["))  # noqa: E731
    assert layers(whole) == ["layers[0]", "layers[1]", "layers[2]", "layers[3]", "layers[4]"]
    assert layers(held) == ["layers[1]", "layers[2]", "layers[4]"]
    grid = "effects.lit, effects.shafts (the light grid)"
    assert 0 < held.parts[grid] < whole.parts[grid]
    assert not any(k.startswith("the filter") for k in held.parts)
    moving = cost.estimate(look.model_copy(update={"layers": [look.layers[i] for i in (1, 2, 4)]}),
                           scene_cached=True)
    # toward the sun, the moving layers only: what the held frame draws of it
    assert abs(held.parts["effects.sun_through_fog"] - moving.parts["effects.sun_through_fog"]) < 1e-12
    assert held.seconds < whole.seconds
    calm = look.model_copy(update={"wind": look.wind.model_copy(update={"speed": 0.0})})
    assert layers(cost.estimate(calm, scene_cached=True, fog_held=True)) == ["layers[2]", "layers[4]"]
    # nothing moves: the held fog is the filtered fog target, no layer and no filter is drawn
    still_noise = calm.model_copy(update={"layers": [look.layers[0], calm.layers[3].model_copy(),
                                                     StillParams.model_validate({"layers": [
                                                         {"kind": "noise", "mode": "volume"}]}).layers[0]]})
    c = cost.estimate(still_noise, scene_cached=True, fog_held=True)
    assert layers(c) == [] and not any(k.startswith("the filter") for k in c.parts)


def test_the_readmes_still_memory_example_holds():
    """README, "Bad input": under the default still memory budget the default look fits at
    3200x1800 with MSAA and not at 3840x2160. It said 3840x2160 fitted, which the estimate
    (held to what the renderer allocates above) had put at 1257 MiB, refused with a 422."""
    from fogbank.model.presets import preset_dict
    from fogbank.settings import Settings
    budget = Settings().still_memory_mb << 20
    look = preset_dict("default")
    fits = cost.estimate(StillParams.model_validate({**look, "width": 3200, "height": 1800}))
    over = cost.estimate(StillParams.model_validate({**look, "width": 3840, "height": 2160}))
    assert fits.memory <= budget
    assert over.memory > budget



# the schema's costly corners (issue 33 finding 4: two 128-sample volume-noise layers of a
# 128^3, 6-octave tile with sunlight through fog, shafts and blur at 1600x900 were
# estimated at 19.7 s against the 20 s budget, accepted, and stopped at 30 s every time)
CORNERS = {
    "volume noise, 64^3 tile": {"layers": [{"kind": "noise", "mode": "volume", "samples": 128}],
                                "effects": {"lit": False, "shafts": 0.0, "sun_through_fog": False}},
    "volume noise, 128^3 tile, lit, shafts, sun, blur": {
        "noise": {"size": 128, "octaves": 6},
        "layers": [{"kind": "noise", "mode": "volume", "samples": 128},
                   {"kind": "noise", "mode": "volume", "samples": 64, "density": 0.5}],
        "effects": {"lit": True, "shafts": 1.0, "sun_through_fog": True, "blur": "separate", "blur_radius": 12}},
    "volume noise, 128^3 tile, shafts only": {"noise": {"size": 128, "octaves": 6},
                                              "layers": [{"kind": "noise", "mode": "volume", "samples": 128}],
                                              "effects": {"lit": False, "shafts": 1.0, "sun_through_fog": False}},
    "the default look, high light grid, fog scale 1": {"effects": {"light_quality": "high", "fog_scale": 1}},
    "16 cosine layers of 8 terms": {"layers": [{"kind": "cosine", "terms": [
        {"amp": 0.1, "k": [0.05 * (j + 1), 0.02, 0.03], "phase": 0.0} for j in range(8)]}] * 16},
}


def _corner(name: str, width: int = 640, height: int = 360) -> StillParams:
    from fogbank.model import presets as P
    return P.patched(CORNERS[name], {**P.preset_dict("default"), "width": width, "height": height}, StillParams)


def test_the_issue_corner_is_estimated_over_the_budget():
    """At 1600x900 the corner is refused now (the default budget is 20 s): measured here
    24.3 s for its first render in a worker of its own, 18.4 s after (scripts/cost_corners.py)."""
    from fogbank.model import presets as P
    look = P.patched({**CORNERS["volume noise, 128^3 tile, lit, shafts, sun, blur"], "width": 1600, "height": 900,
                      "layers": [{"kind": "noise", "mode": "volume", "samples": 128}] * 2},
                     {**P.preset_dict("default"), "width": 1280, "height": 720}, StillParams)
    assert cost.estimate(look, fmt="png").seconds > 20.0


def test_costly_corners_render_within_the_deadline_their_estimate_admits(renderer):
    """Admission: a still is accepted when its estimate is within still_budget_s (20 s)
    and stopped at render_timeout_s (30 s), so no corner may take over 1.5 times its
    estimate. Each corner at 640x360, its camera turned a little each time so that no
    scene pass is reused; the steady render against the estimate without compile and bake
    (the worker has them), timed as a worker times a still (render and encode)."""
    import time
    from fogbank.render.encode import encode
    ratios = {}
    for name in CORNERS:
        look = _corner(name)
        renderer.render(look)   # compile, bake
        took = []
        for k in range(2):
            turned = look.model_copy(update={"camera": look.camera.model_copy(update={"yaw": look.camera.yaw + 0.5 + k})})
            t0 = time.perf_counter()
            encode(renderer.render(turned), "png")
            took.append(time.perf_counter() - t0)
        est = cost.estimate(look, fmt="png", compiled=True, baked=True).seconds
        ratios[name] = (round(min(took), 3), round(est, 3), round(min(took) / est, 2))
    print("\n(measured s, estimated s, ratio):", ratios)
    assert all(r <= 1.5 for _, _, r in ratios.values())
