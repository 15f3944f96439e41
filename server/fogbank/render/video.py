"""Video frames for the stream (issue 34): a session's frames encoded as VP9 or VP8 by
libvpx through PyAV, one encoder per session, kept by the worker that draws its frames.

Why VP9: on fogbank's own frames (the default look playing, 1280x720, 60 frames at 30
fps; `fogbank bench-codecs` measures it again), VP9 in
libvpx's realtime mode at 1 Mbit/s gave 3.2 KB frames at SSIM 0.994 (JPEG q80: 28.7 KB at
0.9936) in 4.3 ms a frame; VP8 3.6 KB at 0.993 in 9 ms; SVT-AV1 (preset 11, CBR, low
delay) 2.4 KB at only 0.991 in 6.7 ms. All three are BSD; x264, which PyAV's wheels also
bundle, is GPL and is never used. VP8 is kept for browsers that decode no VP9.

Each encoder runs with no lookahead (lag-in-frames 0): a frame in, its packet out, its
time stamp the wall clock's (ms), so that libvpx's rate control spends the bitrate over
the frames that really come, not 30 a second. A new encoder, a new size, a new codec or a
new bitrate (libvpx ignores a bitrate changed in place) starts on a keyframe, and
`keyframe` asks for one (a frame dropped after encoding). The rate control starts a
stream a little below its steady quality and raises it over its first 10-20 frames (the
default look at 480x270: SSIM 0.990 on the first keyframe, 0.993 by the 20th frame; JPEG
q80 0.991); a bound on the quantizer (qmax 48-56) lifted only the smallest sizes' first
keyframe and cost 15-60% more bytes in the steady stream, so it is left at libvpx's. An encoder holds about 80 MB at
1280x720 and 150 MB at 1920x1080 (libvpx's frame buffers), so a worker keeps them within
a byte budget (VideoEncoders), and lets them all go when it passes its memory budget
(workers/worker.py)."""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np

# the protocol's codec names (stream/protocol.py) -> libvpx encoders and their options
CODECS = {
    "vp09": ("libvpx-vp9", {"deadline": "realtime", "cpu-used": "8", "lag-in-frames": "0", "row-mt": "1",
                            "error-resilient": "0"}),
    "vp8": ("libvpx", {"deadline": "realtime", "cpu-used": "8", "lag-in-frames": "0"}),
}
BYTES_A_PIXEL = 90     # an encoder's memory, measured: about 78 MB at 1280x720 for VP9
ENCODER_BYTES = 384 * 2**20   # a worker's encoders' memory, at most (about 4 at 720p)


class VideoEncoder:
    """One session's video: `encode(rgb, keyframe, bitrate)` gives its next packet."""

    def __init__(self, codec: str, width: int, height: int, bitrate: int, fps: int = 30, clock=time.monotonic):
        import av
        name, options = CODECS[codec]
        self.codec, self.width, self.height, self.bitrate = codec, width, height, bitrate
        self.ctx = av.CodecContext.create(name, "w")
        self.ctx.width, self.ctx.height, self.ctx.pix_fmt = width, height, "yuv420p"
        self.ctx.time_base = Fraction(1, 1000)   # ms of the wall clock
        self.ctx.framerate = Fraction(fps, 1)
        self.ctx.bit_rate = int(bitrate)
        self.ctx.options = dict(options)
        self.clock = clock
        self.start = clock()
        self.pts = -1

    @property
    def nbytes(self) -> int:
        return BYTES_A_PIXEL * self.width * self.height

    def fits(self, codec: str, width: int, height: int, bitrate: int) -> bool:
        return (codec, width, height, bitrate) == (self.codec, self.width, self.height, self.bitrate)

    def encode(self, img: np.ndarray, keyframe: bool = False) -> tuple[bytes, bool]:
        """`img`: (height, width, 3 or 4) uint8 sRGB (a 4th channel is ignored); returns the
        packet's bytes and whether it is a keyframe."""
        import av
        from av.video.frame import PictureType
        # RGBX as "rgba" (the 4th channel ignored): 2.5 ms to YUV at 720p here, where
        # slicing it to RGB first took 8.7 ms more
        fmt = "rgba" if img.shape[2] == 4 else "rgb24"
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(img), format=fmt).reformat(format="yuv420p")
        self.pts = max(self.pts + 1, int((self.clock() - self.start) * 1000))
        frame.pts = self.pts
        if keyframe:
            frame.pict_type = PictureType.I
        packets = self.ctx.encode(frame)
        data = b"".join(bytes(p) for p in packets)
        if not data:   # with no lookahead every frame gives a packet; a decoder cannot take none
            raise RuntimeError(f"{self.codec} gave no packet for frame {self.pts}")
        return data, any(p.is_keyframe for p in packets)


class VideoEncoders:
    """The encoders of the sessions a worker draws, at most `limit` (the least recently
    used goes first: its session's next frame starts a new one, on a keyframe)."""

    def __init__(self, limit: int = 16, limit_bytes: int = ENCODER_BYTES, clock=time.monotonic):
        self.limit, self.limit_bytes, self.clock = limit, limit_bytes, clock
        self.by_slot: dict[str, VideoEncoder] = {}

    def encode(self, slot: str, codec: str, img: np.ndarray, bitrate: int, keyframe: bool) -> tuple[bytes, bool]:
        h, w = img.shape[:2]
        enc = self.by_slot.pop(slot, None)
        if enc is None or not enc.fits(codec, w, h, bitrate):
            enc = VideoEncoder(codec, w, h, bitrate, clock=self.clock)
            keyframe = True
        self.by_slot[slot] = enc   # most recent last
        while len(self.by_slot) > 1 and (len(self.by_slot) > self.limit or self.nbytes > self.limit_bytes):
            self.by_slot.pop(next(iter(self.by_slot)))
        return enc.encode(img, keyframe)

    @property
    def nbytes(self) -> int:
        return sum(e.nbytes for e in self.by_slot.values())

    def drop(self, slot: str) -> None:
        self.by_slot.pop(slot, None)

    def clear(self) -> None:
        self.by_slot.clear()
