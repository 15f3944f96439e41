"""Where things are in the countryside scene: the house, the bridge, the trees and the
forest, from the terrain alone (numpy, no GL, nothing from the params model). The meshes
are built around them, and the presets place their fog at them."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from fogbank.scene import terrain

HOUSE = terrain.HOUSE_SITE


@dataclass(frozen=True)
class Landmarks:
    house: tuple[float, float, float]
    bridge: tuple[float, float, float]
    trees: tuple[tuple[float, float, float], ...]     # crown centres, the first four named
    forest: tuple[float, float, float]


def tree_spots() -> list[tuple[float, float, str]]:
    rng = np.random.default_rng(2002)
    spots: list[tuple[float, float, str]] = [
        (68.0, -38.0, "pine"), (52.0, -62.0, "pine"), (84.0, -70.0, "oak"), (-22.0, -44.0, "oak")]
    tries = 0
    while len(spots) < 110 and tries < 5000:
        tries += 1
        if rng.random() < 0.8:   # the forest, east of the river
            x, z = rng.normal(75, 24), rng.normal(-60, 26)
        else:                    # scattered trees
            x, z = rng.uniform(-190, 190), rng.uniform(-190, 120)
        if abs(x - float(terrain.river_x(z))) < 14 or abs(z - terrain.ROAD_Z) < 8:
            continue
        if abs(x - HOUSE[0]) < 12 and abs(z - HOUSE[1]) < 11:  # the house
            continue
        if any((x - sx) ** 2 + (z - sz) ** 2 < 20 for sx, sz, _ in spots):
            continue
        spots.append((x, z, "pine" if rng.random() < 0.7 else "oak"))
    return spots


@lru_cache(maxsize=1)
def landmarks() -> Landmarks:
    trees = []
    for x, z, kind in tree_spots()[:4]:
        y = float(terrain.height(x, z))
        trees.append((x, y + (6.0 if kind == "pine" else 5.5), z))
    hx, hz = HOUSE
    bx = float(terrain.river_x(terrain.ROAD_Z))
    # the house's y is its floor, 0.1 m over its terrace (scene/meshes.py _house)
    return Landmarks(house=(hx, float(terrain.height(hx, hz)) + 0.1, hz),
                     bridge=(bx, terrain.BRIDGE_DECK, terrain.ROAD_Z),
                     trees=tuple(trees), forest=(75.0, float(terrain.height(75, -60)) + 5, -60.0))
