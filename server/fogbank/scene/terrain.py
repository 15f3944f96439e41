"""The countryside's ground: a height field with hills, a river valley and a road.

One numpy function, used by the mesh builder (scene.py), the particle collisions and
placement of houses and trees. Units: metres, y up.
"""

from __future__ import annotations

import numpy as np

EXTENT = 220.0        # the terrain covers [-EXTENT, EXTENT] in x and z
WATER_LEVEL = 0.0
ROAD_Z = 0.0          # the road runs along x at this z and crosses the river on the bridge
ROAD_HALF_WIDTH = 3.0
BRIDGE_DECK = 2.4     # height of the bridge deck
HOUSE_SITE = (-40.0, -28.0)   # the house's centre (x, z), on a terrace cut into its slope
HOUSE_PAD = (6.5, 5.0)        # the terrace's half sides (m): the house's 5 x 3.6 and a yard
HOUSE_PAD_BLEND = 12.0        # m over which the terrace meets the slope


def river_x(z):
    """Centre line of the river: it meanders along z."""
    return 10.0 + 22.0 * np.sin(np.asarray(z) / 70.0)


def _raw(x, z):
    dx = x - river_x(z)
    valley = 16.0 * (1.0 - np.exp(-(dx / 55.0) ** 2))
    hills = (4.5 * np.sin(0.031 * x + 0.7) * np.sin(0.027 * z)
             + 2.5 * np.sin(0.06 * x + 0.021 * z) + 2.0 * np.cos(0.047 * z - 0.033 * x))
    away = 1.0 - np.exp(-(dx / 28.0) ** 2)
    channel = -3.2 * np.exp(-(dx / 7.5) ** 2)
    return 1.4 + valley + hills * away + channel


def height(x, z):
    """Ground height at (x, z), with the road's strip levelled across its width and the
    house's terrace levelled at the slope's height under its centre."""
    x = np.asarray(x, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    h = _raw(x, z)
    # the terrace: the house stood on a slope 5 m higher on one side than the other, over a
    # plinth 5.6 m tall (a grey block under the house in every view of it); level within
    # HOUSE_PAD at the slope's height under its centre (cut on the uphill side, filled on
    # the other: at its highest corner's the fill stood 9 m over the slope), blending to the
    # slope over HOUSE_PAD_BLEND by the distance from the pad
    hx, hz = HOUSE_SITE
    out = np.hypot(np.maximum(np.abs(x - hx) - HOUSE_PAD[0], 0.0), np.maximum(np.abs(z - hz) - HOUSE_PAD[1], 0.0))
    p = np.clip(1.0 - out / HOUSE_PAD_BLEND, 0.0, 1.0)
    p = p * p * (3 - 2 * p)
    h = h * (1 - p) + _HOUSE_PAD_Y * p
    # the road: level the ground across the strip toward the height on its centre line,
    # never below the bridge deck's ramp near the river
    road_h = _raw(x, np.full_like(z, ROAD_Z))
    near = np.exp(-((x - river_x(ROAD_Z)) / 16.0) ** 2)
    road_h = np.maximum(road_h, BRIDGE_DECK * near + road_h * (1 - near) - 0.2)
    w = np.clip((ROAD_HALF_WIDTH + 4.0 - np.abs(z - ROAD_Z)) / 4.0, 0.0, 1.0)
    w = w * w * (3 - 2 * w)
    channel = np.exp(-((x - river_x(z)) / 7.5) ** 2)
    return h * (1 - w) + (road_h * (1 - channel) + h * channel) * w


_HOUSE_PAD_Y = float(_raw(np.float64(HOUSE_SITE[0]), np.float64(HOUSE_SITE[1])))


def normal(x, z, eps: float = 0.05):
    """Unit normals of the height field by central differences."""
    hx = (height(x + eps, z) - height(x - eps, z)) / (2 * eps)
    hz = (height(x, z + eps) - height(x, z - eps)) / (2 * eps)
    n = np.stack([-hx, np.ones_like(hx), -hz], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def flat(x, z):
    """The calibration scene's ground plane."""
    return np.zeros_like(np.asarray(x, dtype=np.float64))
