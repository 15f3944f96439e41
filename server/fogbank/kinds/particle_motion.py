"""Fischer's particle simulation, deterministic from a seed and the time.

Each of `count` slots runs a cycle of `life_max` steps: a particle is born at the slot's
staggered offset (the emitter has always been running, so t = 0 is already
in its steady state), lives a random `life_min..life_max` steps, then the slot waits for its
next cycle. A particle's launch direction (a cone of half-angle `spread`), its life and its
per-step jitter come from a counter-based hash of (seed, slot, cycle, step), so the state
at any time t is computed directly, without simulating from t = 0: the same params give
the same particles on any replica. Motion per step: velocity relaxes toward the wind (or
still air) at rate `drag`, plus `gravity`; the particle collides with the terrain and
bounces off it. Positions are interpolated between steps so motion is smooth in time.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Callable

import numpy as np

_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)
FADE_IN_STEPS = 2.0   # a newborn particle's strength ramps from 0 over this many steps


def _splitmix(x: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        x = (x + np.uint64(0x9E3779B97F4A7C15)) & _M64
        x = ((x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _M64
        x = ((x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _M64
        return x ^ (x >> np.uint64(31))


def _hash(seed: int, *keys) -> np.ndarray:
    """The 64-bit hash chain of the seed and integer keys (broadcast): each key is mixed
    into the hash of those before it, so a chain's common start can be hashed once."""
    h = _splitmix(np.asarray(np.uint64(seed)))
    return _chain(h, *keys)


def _chain(h: np.ndarray, *keys) -> np.ndarray:
    for k in keys:
        with np.errstate(over="ignore"):
            h = _splitmix(h ^ np.asarray(k).astype(np.uint64))
    return h


def _unit(h: np.ndarray) -> np.ndarray:
    """A hash as a uniform number in [0, 1): its top 53 bits."""
    return (h >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def uniform(seed: int, *keys) -> np.ndarray:
    """Uniform [0, 1) numbers from a hash of the seed and integer keys (broadcast)."""
    return _unit(_hash(seed, *keys))


def _cone(axis: np.ndarray, spread_rad: float, u1, u2) -> np.ndarray:
    """Unit vectors uniformly distributed in a cone around `axis`."""
    a = axis / np.linalg.norm(axis)
    cos_t = 1.0 - u1 * (1.0 - np.cos(spread_rad))
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
    phi = 2 * np.pi * u2
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = np.cross(a, helper)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(a, b1)
    return (cos_t[:, None] * a + (sin_t * np.cos(phi))[:, None] * b1
            + (sin_t * np.sin(phi))[:, None] * b2)


class Trajectories:
    """Where each particle's integration stopped, by layer, wind and ground, so that the next
    time continues it instead of integrating every particle from its birth again (a look
    playing at 30 frames a second is a step or two further each frame; from birth it was up
    to life_max steps, ~0.1 s per layer of 64 particles of life 1000 on this machine). A
    particle continued is bit for bit the one integrated from birth: the same operations on
    the same float64 numbers, step by step. Keeps the last MAX_LAYERS * 2 layers, and of
    each the states at its last TIMES times (several sessions play one look on a worker,
    each at its own time: with one state, each frame of one found the other's, later,
    state and integrated every life again, 20 ms a frame of the default look); safe across
    threads (the frame's plan and the rays API)."""

    SIZE = 32
    TIMES = 4
    NEXT_S = 1.0   # a state this close after the one it continued is the same session's next

    def __init__(self):
        self._cache: OrderedDict = OrderedDict()   # key -> [state, ...], most recent last
        self._lock = threading.Lock()

    def get(self, key, t: float) -> dict | None:
        """The state to continue from at time `t`: the latest one at or before it (a
        state later than `t` has no particle to continue)."""
        with self._lock:
            states = self._cache.get(key)
            if states is None:
                return None
            self._cache.move_to_end(key)
            before = [s for s in states if s["t"] <= t]
            return max(before, key=lambda s: s["t"]) if before else None

    def put(self, key, value: dict, continued: dict | None = None) -> None:
        """Keep `value` (a state with its time "t"); in place of the state it `continued`
        when that is within NEXT_S before it (a session playing on leaves its own past,
        not another session's far earlier state)."""
        with self._lock:
            drop = continued if continued is not None and value["t"] - continued["t"] <= self.NEXT_S else None
            states = [s for s in self._cache.get(key, []) if s is not drop]
            states.append(value)
            self._cache[key] = states[-self.TIMES:]
            self._cache.move_to_end(key)
            while len(self._cache) > self.SIZE:
                self._cache.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._cache.clear()


TRAJECTORIES = Trajectories()


def simulate(layer, t: float, wind: np.ndarray,
             ground: Callable[[np.ndarray, np.ndarray], np.ndarray],
             cache: Trajectories | None = TRAJECTORIES, ages: bool = False) -> tuple[np.ndarray, ...]:
    """Positions (M, 3) and strengths s_j = remaining life / initial life (M,) of the
    particles alive at time t, faded in over their first FADE_IN_STEPS steps. M <= count.
    With `ages`, also each one's age over its life, in [0, 1) (M,). With `cache`, each
    particle alive at the layer's last simulated time continues from where it stopped
    (None: every particle from its birth)."""
    n = layer.count
    period = layer.life_max
    slots = np.arange(n, dtype=np.int64)
    offset = (slots * period) // n
    tau = t / layer.step - offset                   # steps since the slot's first birth
    cycle = np.floor(tau / period).astype(np.int64)
    age = tau - cycle * period                      # steps since this cycle's birth
    life = layer.life_min + np.floor(
        uniform(layer.seed, slots, cycle, 0) * (layer.life_max - layer.life_min + 1))
    alive = age < life   # cycles before t = 0 count too: the emitter is warm at t = 0
    if not np.any(alive):
        return (np.zeros((0, 3)), np.zeros(0)) + ((np.zeros(0),) if ages else ())
    slots, cycle, age, life = slots[alive], cycle[alive], age[alive], life[alive]

    direction = _cone(np.asarray(layer.direction, dtype=np.float64),
                      np.radians(layer.spread), uniform(layer.seed, slots, cycle, 1),
                      uniform(layer.seed, slots, cycle, 2))
    v = direction * layer.speed
    # born uniformly in the box emitter +- emitter_size (a point when it is 0)
    box = np.stack([uniform(layer.seed, slots, cycle, 3 + i) for i in range(3)], axis=1) * 2.0 - 1.0
    p = np.asarray(layer.emitter, dtype=np.float64) + box * np.asarray(layer.emitter_size, dtype=np.float64)
    target = np.asarray(wind, dtype=np.float64) if layer.wind else np.zeros(3)
    dt = layer.step
    steps = np.floor(age).astype(np.int64)
    prev = p.copy()
    # k0: the first step each particle still has to take (0: from its birth). A particle
    # of the same slot and cycle as last time, not past the steps wanted now, continues
    # from its stored step: p, v after k0 steps and prev after k0 - 1.
    k0 = np.zeros(len(slots), np.int64)
    key = (layer.model_dump_json(), tuple(float(x) for x in target), ground)
    last = cache.get(key, t) if cache is not None else None
    if last is not None:
        idx = np.searchsorted(last["slots"], slots)
        idx = np.minimum(idx, len(last["slots"]) - 1)
        same = (last["slots"][idx] == slots) & (last["cycle"][idx] == cycle) & (last["k"][idx] - 1 <= steps)
        k0 = np.where(same, last["k"][idx], 0)
        p = np.where(same[:, None], last["p"][idx], p)
        v = np.where(same[:, None], last["v"][idx], v)
        prev = np.where(same[:, None], last["prev"][idx], prev)
    # the steps some particle takes: the union of each one's k0..steps (a newborn's first
    # steps and the continued ones' next, not everything in between)
    todo = k0 <= steps
    cover = np.zeros(int(steps.max()) + 2, np.int64)
    np.add.at(cover, k0[todo], 1)
    np.add.at(cover, steps[todo] + 1, -1)
    # each step's jitter is uniform(seed, slot, cycle, 100 + 3 k + axis): the chain's start
    # (seed, slot, cycle) is hashed once, and the step's three keys mixed in at once
    particle = _hash(layer.seed, slots, cycle)[:, None]
    for k in np.flatnonzero(np.cumsum(cover) > 0).tolist():
        moving = (steps >= k) & (k0 <= k)  # after this step, positions at step k+1 are needed by age >= k
        jitter = _unit(_chain(particle, 100 + 3 * k + np.arange(3))) - 0.5
        nv = v + (target - v) * min(1.0, layer.drag * dt)
        nv = nv + np.array([0.0, layer.gravity * dt, 0.0]) + jitter * (0.3 * layer.speed + 0.2) * dt
        npos = p + nv * dt
        g = ground(npos[:, 0], npos[:, 2])
        hit = npos[:, 1] < g
        npos[:, 1] = np.where(hit, g, npos[:, 1])
        nv[:, 1] = np.where(hit, np.abs(nv[:, 1]) * 0.3, nv[:, 1])
        nv[:, [0, 2]] = np.where(hit[:, None], nv[:, [0, 2]] * 0.7, nv[:, [0, 2]])
        prev = np.where(((steps == k) & (k0 <= k))[:, None], p, prev)
        p = np.where(moving[:, None], npos, p)
        v = np.where(moving[:, None], nv, v)
    if cache is not None:
        cache.put(key, {"t": t, "slots": slots, "cycle": cycle, "k": np.maximum(k0, steps + 1),
                        "p": p, "v": v, "prev": prev}, continued=last)
    frac = (age - steps)[:, None]
    pos = prev + (p - prev) * frac
    # Fischer: strength = remaining life / initial life. A particle born at full strength
    # pops into view (fischer-smoke: 0.80 of T between frames 0.1 s apart); it fades in
    # over its first FADE_IN_STEPS steps instead (docs/departures.md)
    strength = (life - age) / life * np.minimum(1.0, age / FADE_IN_STEPS)
    return (pos, strength, age / life) if ages else (pos, strength)
