"""GL resources (render/resources.py): noise tiles baked on a thread of their own."""

from __future__ import annotations

import threading
import time

import numpy as np

from fogbank.kinds.noise_bake import bake


def test_a_noise_tile_bakes_in_the_background_and_is_the_tile_baked_inline(renderer):
    """Issue 33: a stream's frame that needed a new noise tile held its worker for the bake
    (0.3-1.5 s) while every other stream on it waited. `ready` starts the bake on a thread
    and says not ready; later it says ready, and `get` uploads exactly the tile that an
    inline bake makes, counted as baked once."""
    tiles = renderer.noise
    key = (32, 3, 1, 123457)
    baked = tiles.baked
    assert tiles.ready(key) is False
    started = dict(tiles._baking)
    tiles.ready(key)
    assert tiles._baking == started             # asking again starts nothing new
    deadline = time.monotonic() + 30
    while not tiles.ready(key) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert tiles.ready(key) is True
    assert tiles.baked == baked                 # baked on the thread, not yet taken
    tex = tiles.get(key)
    assert tiles.baked == baked + 1 and tiles.ready(key) is True
    got = np.frombuffer(tex.read(), dtype=np.float32).reshape(32, 32, 32)
    want = np.ascontiguousarray(bake(*key).transpose(2, 1, 0))
    assert np.array_equal(got, want)
    # the bake thread yields the cores to the frames' raster threads
    from fogbank.render.resources import BAKE_NICE
    bakers = [t.native_id for t in threading.enumerate() if t.name.startswith("fogbank-bake")]
    assert len(bakers) == 1
    with open(f"/proc/self/task/{bakers[0]}/stat") as f:
        nice = int(f.read().rsplit(")", 1)[1].split()[16])
    assert nice == BAKE_NICE


def test_tiles_asked_for_and_never_taken_do_not_pile_up(renderer):
    from fogbank.render.resources import NOISE_TILES
    tiles = renderer.noise
    for seed in range(NOISE_TILES + 3):
        tiles.ready((16, 2, 1, 900 + seed))
    assert len(tiles._baking) <= NOISE_TILES
