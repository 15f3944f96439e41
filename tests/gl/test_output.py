"""The readback (render/passes/output.py): the frame's image is the output target's pixels
top row first, read into its size's kept buffer (render/targets.py Targets.readback);
Renderer.render hands the caller a copy unless told to lend the buffer; the buffer counts
against the caches' budget and goes with its targets; and a worker's frame, with the
worker's fixed mmap threshold, maps no new memory."""

from __future__ import annotations

import ctypes.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fogbank.model.params import StillParams
from fogbank.model.presets import preset_dict
from fogbank.render.passes import FRAME_PASSES
from fogbank.render.targets import READBACK_BPP


def _look(w: int, h: int, density: float = 1.0) -> StillParams:
    return StillParams.model_validate({**preset_dict("default"), "width": w, "height": h, "density": density})


def test_the_image_is_the_output_target_top_row_first(renderer):
    w, h = 203, 117
    f = renderer.begin(_look(w, h), "output-test", True)
    for p in FRAME_PASSES:
        p.run(renderer, f)
    # an independent read of the same target: GL's rows are bottom first
    raw = np.frombuffer(f.targets.out.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
    assert f.image.shape == (h, w, 3)
    assert f.image.flags["C_CONTIGUOUS"]
    assert np.array_equal(f.image, raw[::-1])
    assert np.array_equal(f.image[0], raw[h - 1])
    renderer.keep_only(f)
    renderer.drop_slot("output-test")


def test_render_returns_a_copy_the_caller_owns_unless_lent(renderer):
    w, h = 160, 90
    a = renderer.render(_look(w, h, 1.0), slot="output-test")
    kept = a.copy()
    b = renderer.render(_look(w, h, 4.0), slot="output-test")
    assert not np.array_equal(a, b)          # the two looks differ
    assert np.array_equal(a, kept)           # and the first image was not overwritten
    assert not np.shares_memory(a, b)
    lent1 = renderer.render(_look(w, h, 1.0), slot="output-test", lend=True)
    lent2 = renderer.render(_look(w, h, 4.0), slot="output-test", lend=True)
    assert np.shares_memory(lent1, lent2)    # one buffer a size, overwritten by the next frame
    assert np.array_equal(lent2, b)
    assert np.array_equal(kept, a)
    renderer.drop_slot("output-test")


def test_the_readback_counts_against_the_budget_and_goes_with_its_targets(renderer):
    from fogbank.render.renderer import Renderer
    r = Renderer(renderer.ctx, cache_bytes=64 << 20)
    w, h = 96, 54
    lent = r.render(_look(w, h), slot="output-test", lend=True)
    t = r.caches.targets(w, h)
    raw, image = t.readback()
    assert np.shares_memory(image, lent)     # the frame's own buffer, not one made by this call
    assert len(raw) == w * h * 3 and image.shape == (h, w, 3)
    kept = t._readback
    t._readback = None
    without = t.nbytes()
    t._readback = kept
    assert t.nbytes() - without == w * h * READBACK_BPP
    r.release_caches()   # the targets go, their readback with them
    assert t._readback is None
    assert t.nbytes() == w * h * 4    # the output renderbuffer's size is all it counts then


WORKER_FRAMES = Path(__file__).resolve().parents[2] / "scripts" / "worker_frames.py"


@pytest.mark.skipif(ctypes.util.find_library("c") is None, reason="the worker's malloc settings are glibc's")
def test_a_worker_frame_maps_no_new_memory():
    """A worker process (its own malloc thresholds, workers/worker.py) drawing 1280x720
    stream frames with the camera still, then 448x252 previews of an orbiting camera
    (scripts/worker_frames.py): the page faults a frame, against the 675 pages (4 KiB) one
    fresh 1280x720 readback buffer would take. Before the kept buffer the still frames took 1352 a frame: the read and the
    contiguous copy for the encoder, each a new mapping (3.6 ms of system time); before the
    trim threshold, the previews took 383-414, the heap's top given back and faulted in
    again at every frame."""
    out = subprocess.run([sys.executable, str(WORKER_FRAMES), "--frames", "10", "--json"],
                         capture_output=True, text=True, timeout=240)
    assert out.returncode == 0, out.stderr[-2000:]
    faults = json.loads(out.stdout.strip().splitlines()[-1])
    assert faults["still 1280x720"] < 50
    assert faults["orbit 448x252"] < 50
