"""The G-buffer's list of silhouette tiles (render/targets.py GBuffer.silhouette_tiles):
the tiles the composite's second draw covers, against the tiles computed in numpy from
the resolve's far surfaces (a pixel sees two surfaces where the near one's coverage, in
the far colour's alpha, is below 1), listed anew for each scene pass drawn."""

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
    tex, count = g.silhouette_tiles(renderer.ctx)
    return np.frombuffer(tex.read(), np.int32)[:count]


def test_the_listed_tiles_are_those_with_a_pixel_of_two_surfaces(renderer):
    g = _frame(renderer, 0.0)
    expected = _expected(g)
    assert len(expected) > 20   # the default view has silhouettes: trees, the house, the hills
    assert np.array_equal(_listed(renderer, g), expected)


def test_a_new_scene_pass_lists_its_own_tiles(renderer):
    first = _listed(renderer, _frame(renderer, 0.0)).copy()
    g = _frame(renderer, 40.0)
    expected = _expected(g)
    assert not np.array_equal(expected, first)
    assert np.array_equal(_listed(renderer, g), expected)
