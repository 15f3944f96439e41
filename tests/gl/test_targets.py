"""The G-buffer's list of silhouette tiles (render/targets.py GBuffer.silhouette_tiles):
the tiles the composite's second draw covers, as runs along the tile rows, against the
tiles computed in numpy from the resolve's far surfaces (a pixel sees two surfaces where
the near one's coverage, in the far colour's alpha, is below 1), listed anew for each
scene pass drawn; and the worker caches' eviction order (TargetCache.eviction_order)."""

from __future__ import annotations

import numpy as np

from fogbank.model.params import StillParams
from fogbank.model.presets import preset_dict
from fogbank.render.passes import FRAME_PASSES
from fogbank.render.targets import SILHOUETTE_TILE


def _frame(renderer, yaw: float):
    d = {**preset_dict("default"), "width": 203, "height": 117}   # neither side a whole number of tiles
    s = StillParams.model_validate(d)
    s = s.model_copy(update={"camera": s.camera.model_copy(update={"yaw": s.camera.yaw + yaw})})
    f = renderer.begin(s, "tiles-test", True)
    for p in FRAME_PASSES:
        p.run(renderer, f)
    renderer.keep_only(f)
    return f.gbuffer


def _expected(g) -> np.ndarray:
    far = np.frombuffer(g.far_color.read(), np.float16).reshape(g.far_color.height, g.far_color.width, 4)
    two = far[..., 3].astype(np.float64) < 1.0
    t = SILHOUETTE_TILE
    rows, cols = -(-two.shape[0] // t), -(-two.shape[1] // t)
    padded = np.zeros((rows * t, cols * t), bool)
    padded[:two.shape[0], :two.shape[1]] = two
    marked = padded.reshape(rows, t, cols, t).any(axis=(1, 3))
    return np.flatnonzero(marked.ravel())


def _listed(renderer, g) -> np.ndarray:
    """The tiles the listed runs cover, each run within one row of the tile grid."""
    tex, count = g.silhouette_tiles(renderer.ctx)
    runs = np.frombuffer(tex.read(), np.int32).reshape(-1, 2)[:count]
    cols = g.tiles.width
    assert all(start % cols + n <= cols and n >= 1 for start, n in runs)
    return np.concatenate([np.arange(start, start + n) for start, n in runs] or [np.zeros(0, int)])


def test_the_listed_tiles_are_those_with_a_pixel_of_two_surfaces(renderer):
    g = _frame(renderer, 0.0)
    expected = _expected(g)
    assert len(expected) > 20   # the default view has silhouettes: trees, the house, the hills
    assert np.array_equal(_listed(renderer, g), expected)
    assert g.tile_count < len(expected) / 2   # runs along the rows, not one quad a tile


def test_a_new_scene_pass_lists_its_own_tiles(renderer):
    first = _listed(renderer, _frame(renderer, 0.0)).copy()
    g = _frame(renderer, 40.0)
    expected = _expected(g)
    assert not np.array_equal(expected, first)
    assert np.array_equal(_listed(renderer, g), expected)


def _cached_frames(r, slots: list[str], rounds: int, now: list[float], step: float = 0.05,
                   orbiting=()) -> dict[str, int]:
    """Frames of each slot, drawn in turn for `rounds`, the clock moving `step` s a frame
    (the slots in `orbiting` turning their camera a degree a frame); how many found their
    scene pass cached."""
    still = StillParams.model_validate({**preset_dict("default"), "width": 160, "height": 90})
    hits = {s: 0 for s in slots}
    for i in range(rounds):
        for s in slots:
            look = still
            if s in orbiting:
                look = still.model_copy(update={"camera": still.camera.model_copy(update={"yaw": float(i)})})
            f = r.begin(look, s, True)
            hits[s] += f.scene_cached
            for p in FRAME_PASSES:
                p.run(r, f)
            r.keep_only(f)
            now[0] += step
    return hits


def _budget(renderer, scene_passes: float) -> int:
    """A cache budget of one 160x90 frame's scratch targets and `scene_passes` of its scene passes."""
    from fogbank.render.renderer import Renderer
    probe = Renderer(renderer.ctx, cache_bytes=1 << 30)
    _cached_frames(probe, ["probe"], 1, [0.0])
    t = probe.caches.targets(160, 90).nbytes()
    g = probe.caches.nbytes() - t   # the one scene pass
    probe.release_caches()
    return int(t + scene_passes * g)


def test_sessions_drawn_in_turn_keep_the_scene_passes_that_fit(renderer):
    """Three sessions drawn in turn where two scene passes fit: the two that hold one keep
    it and only the third redraws. Least-recently-used evicted at each frame the scene
    pass the next frame needed: no frame found its own (0 hits of 12)."""
    from fogbank.render.renderer import Renderer
    now = [0.0]
    r = Renderer(renderer.ctx, cache_bytes=_budget(renderer, 2.5), clock=lambda: now[0])
    hits = _cached_frames(r, ["a", "b", "c"], 5, now)
    assert hits == {"a": 4, "b": 4, "c": 0}   # each slot's first frame draws its scene pass
    r.release_caches()


def test_a_session_that_stops_drawing_gives_its_scene_pass_to_one_that_draws(renderer):
    """A scene pass no frame asked for in ACTIVE_S goes first: after 'a' stops, 'c' (which
    could not keep one while both others drew) keeps its own."""
    from fogbank.render.renderer import Renderer
    from fogbank.render.targets import ACTIVE_S
    now = [0.0]
    r = Renderer(renderer.ctx, cache_bytes=_budget(renderer, 2.5), clock=lambda: now[0])
    _cached_frames(r, ["a", "b", "c"], 2, now)
    now[0] += ACTIVE_S + 0.1
    hits = _cached_frames(r, ["b", "c"], 3, now)
    assert hits == {"b": 3, "c": 2}
    r.release_caches()


def test_a_session_whose_camera_moves_leaves_its_place_to_one_that_reuses_it(renderer):
    """'a' orbits (each frame redraws its scene pass), 'b' and 'c' hold still, two scene
    passes fit: 'a' came first, but keeping its pass saves nothing, so 'c' takes it."""
    from fogbank.render.renderer import Renderer
    now = [0.0]
    r = Renderer(renderer.ctx, cache_bytes=_budget(renderer, 2.5), clock=lambda: now[0])
    hits = _cached_frames(r, ["a", "b", "c"], 5, now, orbiting={"a"})
    assert hits == {"a": 0, "b": 4, "c": 3}   # 'c' finds its pass from its third frame
    r.release_caches()


def test_the_scratch_targets_of_a_size_no_longer_drawn_go_before_scene_passes_in_use(renderer):
    """Found in the benchmark: after eight 640x360 streams ended, two 1280x720 streams lost a
    scene pass every fourth frame to the 640x360 scratch targets (12 frames a second
    together, 31-34 on a fresh worker). Six sessions whose scene passes fit only without an
    idle size's scratch targets: with them gone, every frame after each session's first
    finds its scene pass."""
    from fogbank.render.renderer import Renderer
    from fogbank.render.targets import ACTIVE_S
    small = StillParams.model_validate({**preset_dict("default"), "width": 64, "height": 64})
    probe = Renderer(renderer.ctx, cache_bytes=1 << 30)
    _cached_frames(probe, ["probe"], 1, [0.0])
    t = probe.caches.targets(160, 90).nbytes()
    g = probe.caches.nbytes() - t
    probe.render(small, slot="probe")
    t_small = probe.caches.targets(64, 64).nbytes()
    probe.release_caches()
    budget = int(t + t_small / 2 + 6 * g)
    assert t + t_small <= budget // 2   # both sizes' scratch targets fit their half
    now = [0.0]
    r = Renderer(renderer.ctx, cache_bytes=budget, clock=lambda: now[0])
    r.render(small, slot="gone")
    r.drop_slot("gone")
    now[0] += ACTIVE_S + 0.1
    slots = [f"s{i}" for i in range(6)]
    hits = _cached_frames(r, slots, 4, now)
    assert hits == {s: 3 for s in slots}
    r.release_caches()
