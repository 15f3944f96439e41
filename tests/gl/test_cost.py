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

