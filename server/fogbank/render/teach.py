"""Views that teach: instead of the shaded frame, what the fog is made of.

- "transmittance": the fog's T per pixel, black (T = 0) to white (T = 1);
- "optical_depth": one layer's optical depth tau = -ln T_j (the look with only that
  layer), on a colour scale from 0 to the 99th percentile of its non-zero pixels
  (scale_top; above it, the top colour);
- "difference": |T_analytic - T_raymarch| per pixel, the closed forms against a
  RAYMARCH_STEPS-step raymarch of the same look (exponential layers; the others are the
  same closed form in both), on the same kind of scale, with its max and the 99th
  percentile over all pixels. Where they differ, it is the raymarch that errs: the closed forms match float64
  quadrature (docs/accuracy.md), while a fixed step aliases fine waves on long rays.

Each is drawn from the fog target (raw T per fog texel, before the global effects; in
the difference view, the analytic T unfiltered against the raymarch) and
comes with its numbers and a legend (the colour stops and the values at each end), so
the page draws the same scale the picture uses.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fogbank.render.passes.fog_filter import jittered
from fogbank.render.probes import fog_frame, fog_texels

SHOWS = ("shaded", "transmittance", "optical_depth", "difference")
RAYMARCH_STEPS = 256

# viridis, sampled at nine stops from matplotlib's table (perceptually even, readable in
# grey): the image and the page's legend both use these
VIRIDIS = np.array([
    (0x44, 0x01, 0x54), (0x47, 0x2c, 0x7a), (0x3b, 0x51, 0x8b), (0x2c, 0x71, 0x8e), (0x21, 0x90, 0x8d),
    (0x27, 0xad, 0x81), (0x5c, 0xc8, 0x63), (0xaa, 0xdc, 0x32), (0xfd, 0xe7, 0x25)], np.float64)
GREYS = np.array([(0, 0, 0), (255, 255, 255)], np.float64)


def colour(v: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """v in [0, 1] -> RGB uint8, linear between evenly spaced stops."""
    x = np.clip(v, 0.0, 1.0) * (len(stops) - 1)
    i = np.minimum(x.astype(int), len(stops) - 2)
    t = (x - i)[..., None]
    return np.round(stops[i] * (1 - t) + stops[i + 1] * t).astype(np.uint8)


def _to_view(texels: np.ndarray, width: int, height: int) -> np.ndarray:
    """Fog texels (bottom row first) to the view's pixels, top row first (nearest)."""
    th, tw = texels.shape[:2]
    rows = (np.arange(height) * th) // height
    cols = (np.arange(width) * tw) // width
    return texels[::-1][rows][:, cols]


def scale_top(v: np.ndarray) -> float:
    """The top of a view's colour scale: the 99th percentile of its non-zero pixels (a
    few grazing rays at the horizon would flatten the rest under the max; a layer that
    covers under 1% of the view would vanish under the percentile of all pixels)."""
    nz = v[v > 0]
    return float(np.percentile(nz, 99)) if nz.size else 0.0


def _legend(stops: np.ndarray, lo: float, hi: float, label: str) -> dict[str, Any]:
    return {"colors": ["#%02x%02x%02x" % tuple(int(c) for c in s) for s in stops],
            "lo": lo, "hi": hi, "label": label}


def _raw_t(r, still, slot: str, raymarch_steps: int | None = None) -> np.ndarray:
    """The fog target's T (jittered looks through their filter, as a frame shows them;
    the raymarch's own samples are not jittered)."""
    f = fog_frame(r, still, raymarch_steps, filtered=jittered(still) and not raymarch_steps, slot=slot)[1]
    t = fog_texels(f)[..., 0].astype(np.float64)
    # the caches hold this size and this session's scene pass, as after a shaded frame
    r.keep_only(f)
    return t


def render(r, still, show: str, layer: int = 0, slot: str = "teach") -> tuple[np.ndarray, dict[str, Any]]:
    """(the view as (height, width, 3) uint8, top row first; its numbers and legend)."""
    w, h = still.width, still.height
    if show == "transmittance":
        t = _to_view(_raw_t(r, still, slot), w, h)
        stats = {"show": show, "min": float(t.min()), "mean": float(t.mean()),
                 "legend": _legend(GREYS, 0.0, 1.0, "transmittance T")}
        return colour(t, GREYS), stats
    if show == "optical_depth":
        if not 0 <= layer < len(still.layers):
            raise ValueError(f"view.layer = {layer}: this look has {len(still.layers)} layer(s), "
                             f"0 to {len(still.layers) - 1}")
        one = still.model_copy(update={"layers": [still.layers[layer].model_copy(update={"enabled": True})]})
        # T = 0 (an opaque particle) has no finite depth: shown at the top of the scale
        tau = -np.log(np.maximum(_to_view(_raw_t(r, one, slot), w, h), 1e-30))
        top = scale_top(tau)
        stats = {"show": show, "layer": layer, "kind": still.layers[layer].kind, "max": float(tau.max()),
                 "p99": top, "mean": float(tau.mean()),
                 "legend": _legend(VIRIDIS, 0.0, top, f"optical depth of layer {layer + 1}")}
        return colour(tau / top if top > 0 else tau * 0, VIRIDIS), stats
    if show == "difference":
        analytic = _to_view(_raw_t(r, still, slot), w, h)
        marched = _to_view(_raw_t(r, still, slot, RAYMARCH_STEPS), w, h)
        d = np.abs(analytic - marched)
        top = scale_top(d)
        stats = {"show": show, "max_abs_dT": float(d.max()), "p99_abs_dT": float(np.percentile(d, 99)),
                 "steps": RAYMARCH_STEPS,
                 "legend": _legend(VIRIDIS, 0.0, top, f"|T analytic - T raymarch, {RAYMARCH_STEPS} steps|")}
        return colour(d / top if top > 0 else d, VIRIDIS), stats
    raise ValueError(f"view.show = {show!r}: one of {', '.join(SHOWS)}")
