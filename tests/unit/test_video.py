"""render/video.py: each session's VP9/VP8 encoder. Packets decoded by PyAV's own decoders
(libvpx's and FFmpeg's, apart from the encoder) against the frames that went in."""

from __future__ import annotations

import av
import numpy as np
import pytest

from fogbank.render.video import VideoEncoders


def _frames(n: int, w: int = 160, h: int = 96) -> list[np.ndarray]:
    """Smooth moving gradients as RGBX (as the renderer reads frames back for the stream)."""
    y, x = np.mgrid[0:h, 0:w].astype(float)
    out = []
    for k in range(n):
        img = np.empty((h, w, 4), np.uint8)
        img[..., 0] = (127 + 100 * np.sin(x / 17 + k / 5)).astype(np.uint8)
        img[..., 1] = (127 + 100 * np.cos(y / 13 - k / 7)).astype(np.uint8)
        img[..., 2] = ((x + y + 3 * k) % 256).astype(np.uint8) // 2 + 60
        img[..., 3] = 255
        out.append(img)
    return out


class Clock:
    """Frames 1/30 s apart, whenever they are encoded (the encoder stamps them by it)."""

    def __init__(self):
        self.t = 0.0

    def __call__(self) -> float:
        self.t += 1 / 30
        return self.t


def _psnr(a, b) -> float:
    return float(10 * np.log10(255.0 ** 2 / max(((a.astype(float) - b.astype(float)) ** 2).mean(), 1e-9)))


@pytest.mark.parametrize("codec, decoder", [("vp09", "vp9"), ("vp8", "vp8")])
def test_packets_decode_to_the_frames_and_start_on_a_keyframe(codec, decoder):
    encs = VideoEncoders(clock=Clock())
    dec = av.CodecContext.create(decoder, "r")
    keys, psnrs = [], []
    for img in _frames(12):
        data, key = encs.encode("s1", codec, img, 400_000, False)
        keys.append(key)
        for d in dec.decode(av.Packet(data)):
            psnrs.append(_psnr(d.to_ndarray(format="rgb24"), img[..., :3]))
    assert keys[0] is True and not any(keys[1:])
    assert len(psnrs) == 12
    assert min(psnrs[2:]) >= 30.0


def test_a_keyframe_when_asked_on_a_new_size_and_per_session():
    encs = VideoEncoders(limit=2, clock=Clock())
    imgs = _frames(4)
    assert encs.encode("a", "vp09", imgs[0], 400_000, False)[1] is True
    assert encs.encode("a", "vp09", imgs[1], 400_000, False)[1] is False
    assert encs.encode("a", "vp09", imgs[2], 400_000, True)[1] is True      # asked
    assert encs.encode("b", "vp09", imgs[0], 400_000, False)[1] is True     # another session
    small = _frames(1, 96, 64)[0]
    assert encs.encode("a", "vp09", small, 400_000, False)[1] is True       # a new size
    assert encs.encode("a", "vp09", small, 400_000, False)[1] is False
    assert encs.encode("a", "vp09", small, 566_000, False)[1] is True       # another bitrate
    encs.encode("c", "vp09", imgs[0], 400_000, False)                       # a third: the oldest goes
    assert set(encs.by_slot) == {"a", "c"}
    encs.drop("a")
    assert set(encs.by_slot) == {"c"}


def test_encoders_are_kept_within_their_byte_budget():
    """About 90 bytes a pixel each (78 MB measured at 720p): a worker keeps the most recent
    within the budget, and always the one it is using."""
    img = _frames(1, 160, 96)[0]
    one = 90 * 160 * 96
    encs = VideoEncoders(limit_bytes=int(2.5 * one), clock=Clock())
    for slot in "abcd":
        encs.encode(slot, "vp09", img, 400_000, False)
    assert list(encs.by_slot) == ["c", "d"]
    assert VideoEncoders(limit_bytes=1, clock=Clock()).encode("x", "vp09", img, 400_000, False)[1] is True
