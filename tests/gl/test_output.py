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
    kept = dict(t._readback)
    t._readback.clear()
    without = t.nbytes()
    t._readback.update(kept)
    assert t.nbytes() - without == w * h * READBACK_BPP
    r.release_caches()   # the targets go, their readback with them
    assert t._readback == {}
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


def test_a_frame_read_as_rgbx_is_the_rgb_frame_and_encodes_to_the_same_jpeg(renderer):
    """A stream frame reads back 4 bytes a pixel (Renderer.render channels=4, for the JPEG
    encoder): the same pixels as the 3-byte read, alpha 255, top row first against an
    independent read() of the target flipped by hand; the JPEG of both is the same bytes;
    a PNG of it is the RGB image's PNG; and its buffers count in the targets' bytes."""
    from fogbank.render.encode import encode
    from fogbank.render.renderer import Renderer
    r = Renderer(renderer.ctx, cache_bytes=64 << 20)
    w, h = 203, 117   # rows of 609 and 812 bytes: neither packs to 4-byte alignment alone
    look = _look(w, h)
    rgb = r.render(look, slot="rgbx-test")
    rgbx = r.render(look, slot="rgbx-test", channels=4)
    t = r.caches.targets(w, h)
    by_hand = np.frombuffer(t.out.read(components=4, alignment=1), np.uint8).reshape(h, w, 4)[::-1]
    assert rgbx.shape == (h, w, 4) and np.array_equal(rgbx, by_hand)
    assert np.array_equal(rgbx[..., :3], rgb) and int(rgbx[..., 3].min()) == 255
    assert float(rgb.std()) > 10.0   # a picture, not a flat fill: the check has teeth
    assert encode(rgbx, "jpg", 80) == encode(rgb, "jpg", 80)
    assert encode(rgbx, "png") == encode(rgb, "png")
    both = t.nbytes()
    rgbx_buffers = t._readback.pop(4)
    assert both - t.nbytes() == w * h * 2 * 4   # the RGBX read and its flipped image
    t._readback[4] = rgbx_buffers
    r.release_caches()
