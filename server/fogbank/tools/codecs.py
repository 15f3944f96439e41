"""Which video codec the stream uses (issue 34): fogbank's own frames (the default look with
time running, 60 frames at 30 fps, as a stream draws them) encoded by JPEG q80 and by VP8,
VP9 (libvpx, realtime) and AV1 (SVT-AV1, low delay) through PyAV at several bitrates: bytes
a frame, ms a frame to encode (YUV conversion included) and SSIM to the frame drawn (on
luma, 7x7 windows), at 640x360, 1280x720 and 1920x1080. `fogbank bench-codecs`."""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np

from fogbank.render.video import CODECS

SIZES = ((640, 360), (1280, 720), (1920, 1080))
RATES_720P = (0.5e6, 1e6, 1.5e6, 3e6)   # bits a second at 1280x720, in proportion to pixels elsewhere
# VP8 and VP9 as the stream sets them (render/video.py CODECS), AV1 for the comparison:
# (encoder, decoder, options)
ENCODERS = {
    "vp8": (CODECS["vp8"][0], "vp8", CODECS["vp8"][1]),
    "vp9": (CODECS["vp09"][0], "vp9", CODECS["vp09"][1]),
    "av1": ("libsvtav1", "libdav1d", {"preset": "12", "svtav1-params": "pred-struct=1:lp=2:rc=2"}),
}


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM of the luma of two RGB images (Wang et al. 2004, 7x7 uniform windows)."""
    from scipy.ndimage import uniform_filter
    w = np.array([0.299, 0.587, 0.114])
    a, b = a[..., :3].astype(np.float64) @ w, b[..., :3].astype(np.float64) @ w
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    ma, mb = uniform_filter(a, 7), uniform_filter(b, 7)
    va, vb = uniform_filter(a * a, 7) - ma ** 2, uniform_filter(b * b, 7) - mb ** 2
    cov = uniform_filter(a * b, 7) - ma * mb
    return float((((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma ** 2 + mb ** 2 + c1) * (va + vb + c2))).mean())


def frames(w: int, h: int, n: int) -> list[np.ndarray]:
    from fogbank.model import presets as P
    from fogbank.model.params import StillParams
    from fogbank.render.renderer import Renderer, create_context
    r = Renderer(create_context())
    base = P.preset_dict("default")
    return [r.render(StillParams.model_validate({**base, "width": w, "height": h, "time": 3.0 + k / 30}),
                     "codecs", True, hold_fog=True, channels=4) for k in range(n)]


def encode_run(name: str, imgs: list[np.ndarray], rate: float) -> dict:
    import av
    enc_name, dec_name, opts = ENCODERS[name]
    h, w = imgs[0].shape[:2]
    enc = av.CodecContext.create(enc_name, "w")
    enc.width, enc.height, enc.pix_fmt = w, h, "yuv420p"
    enc.time_base, enc.framerate = Fraction(1, 30), Fraction(30, 1)
    enc.bit_rate = int(rate)
    enc.options = dict(opts)
    dec = av.CodecContext.create(dec_name, "r")
    sizes, ms, ss = [], [], []
    for i, img in enumerate(imgs):
        t0 = time.perf_counter()
        vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(img), format="rgba").reformat(format="yuv420p")
        vf.pts = i
        packets = enc.encode(vf)
        ms.append((time.perf_counter() - t0) * 1000)
        for p in packets:
            sizes.append(p.size)
            for d in dec.decode(p):
                if i >= 10 and i % 5 == 0:
                    ss.append(ssim(img, d.to_ndarray(format="rgb24")))
    return {"kB": float(np.mean(sizes[10:])) / 1024, "ms": float(np.median(ms[10:])), "ssim": float(np.mean(ss)),
            "mbps": float(np.mean(sizes[10:])) * 8 * 30 / 1e6}


def run(n: int = 60, out: str | None = None) -> list[dict]:
    from fogbank.render.encode import encode
    import simplejpeg
    rows = []
    for w, h in SIZES:
        imgs = frames(w, h, n)
        t0 = time.perf_counter()
        jpegs = [encode(img, "jpg", 80) for img in imgs]
        jms = (time.perf_counter() - t0) * 1000 / n
        js = float(np.mean([ssim(img, simplejpeg.decode_jpeg(j)) for img, j in zip(imgs[10::5], jpegs[10::5])]))
        rows.append({"size": f"{w}x{h}", "codec": "jpeg q80", "kB": float(np.mean([len(j) for j in jpegs])) / 1024,
                     "ms": jms, "ssim": js, "mbps": float(np.mean([len(j) for j in jpegs])) * 8 * 30 / 1e6})
        print(rows[-1], flush=True)
        for name in ENCODERS:
            for r720 in RATES_720P:
                rate = r720 * w * h / (1280 * 720)
                row = {"size": f"{w}x{h}", "codec": f"{name} {rate / 1e6:.2f} Mbit/s", **encode_run(name, imgs, rate)}
                rows.append(row)
                print(row, flush=True)
    if out:
        lines = ["# fogbank benchmark: video codecs on fogbank's frames (issue 34)", "",
                 "`fogbank bench-codecs`: " + (__doc__ or "").split("\n\n")[0].replace("\n", " "), "",
                 "| size | codec, target | KB a frame | Mbit/s at 30 fps | encode ms | SSIM |", "|---|---|---|---|---|---|"]
        lines += [f"| {r['size']} | {r['codec']} | {r['kB']:.1f} | {r['mbps']:.2f} | {r['ms']:.1f} | {r['ssim']:.4f} |"
                  for r in rows]
        with open(out, "w") as fh:
            fh.write("\n".join(lines) + "\n")
    return rows
