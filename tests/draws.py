"""Random fog layers and rays for the tests (numpy Generator in, params out).

Scene-scale layers come from each kind's own draw (`Kind.sample`, kinds/<name>.py), so a
new kind is drawn here without a test edit. tests/domain.py draws from the whole schema.
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds import KINDS

EXPONENTIAL = [name for name, k in KINDS.items() if k.optical_depth is not None]
ALL = list(KINDS)


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_layer(kind, rng):
    return KINDS[kind].sample(rng)


def random_rays(rng, n, max_len=150.0):
    O = rng.normal(size=(n, 3)) * 15
    W = unit(rng.normal(size=(n, 3)))
    D = rng.uniform(0, max_len, n)
    # a few degenerate rays: along the axes and of zero length
    axes = unit(np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [-1, 0, 0], [0, 0, -1]], float))
    W[:6] = axes
    D[6] = 0.0
    return O, W, D
