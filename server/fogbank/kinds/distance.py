"""Distance fog (Gawron 3.1, 3.3): F = clamp(N ((d - start) / D)^e, 0, max), T = 1 - F."""

from __future__ import annotations

import numpy as np

from fogbank.kinds import noise_bake as bake
from fogbank.kinds.rays import slide


def transmittance(layer, tex, O, omega, d, t, wind):
    P = O + omega * d[:, None]
    n = bake.sample(tex, slide(layer, P, t, wind), layer.noise_scale)
    N = layer.low + (layer.high - layer.low) * n
    x = np.maximum(d - layer.start, 0.0) / layer.distance
    F = np.clip(N * x**layer.exponent, 0.0, layer.max)
    return 1.0 - F
