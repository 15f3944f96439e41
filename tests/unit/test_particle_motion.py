"""Fischer's particle simulation: deterministic from seed and time, lives in the seed's
ranges, collides with the terrain, strength = remaining / initial life."""

from __future__ import annotations

import numpy as np

from fogbank.scene import terrain
from fogbank.kinds.particles import Particles
from fogbank.kinds.particle_motion import simulate, uniform

WIND = np.array([2.0, 0.0, -1.0])


def test_deterministic_and_seeded():
    p = Particles(count=200, seed=5)
    a = simulate(p, 7.3, WIND, terrain.height)
    b = simulate(p, 7.3, WIND, terrain.height)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    c = simulate(p.model_copy(update={"seed": 6}), 7.3, WIND, terrain.height)
    assert not np.array_equal(a[0], c[0])


def test_hash_is_uniform():
    u = uniform(3, np.arange(100000), 7, 1)
    assert 0 <= u.min() and u.max() < 1
    assert abs(u.mean() - 0.5) < 0.01
    assert abs(np.histogram(u, 10)[0] / 10000 - 1).max() < 0.05


def test_lives_in_seed_ranges_and_strength():
    for lo, hi in ((8, 16), (64, 128)):   # smoke and fog, as in Fischer
        p = Particles(count=500, life_min=lo, life_max=hi, step=0.1)
        for t in (3.0, 50.0, 1000.0):
            pos, s = simulate(p, t, WIND, terrain.flat)
            assert len(pos) > 0
            assert s.min() >= 0 and s.max() <= 1
            # the fraction alive matches E[life] / period
            expect = (lo + hi) / 2 / hi
            assert abs(len(pos) / p.count - expect) < 0.12


def test_particles_collide_with_terrain():
    p = Particles(count=300, emitter=(30.0, 40.0, -20.0), direction=(0.0, -1.0, 0.0), speed=10.0,
                  gravity=-9.8, life_min=100, life_max=120, step=0.1, drag=0.0)
    pos, _ = simulate(p, 11.0, WIND, terrain.height)
    ground = terrain.height(pos[:, 0], pos[:, 2])
    assert (pos[:, 1] >= ground - 1e-9).all()
    assert np.mean(pos[:, 1] - ground < 0.5) > 0.5   # most of them landed


def test_motion_is_continuous_in_time():
    p = Particles(count=50, life_min=64, life_max=64, step=0.1)
    a, _ = simulate(p, 2.000, WIND, terrain.flat)
    b, _ = simulate(p, 2.001, WIND, terrain.flat)
    assert len(a) == len(b)
    assert np.abs(a - b).max() < 0.05


def test_wind_carries_sensitive_particles():
    still = Particles(count=100, wind=False, speed=0.0, drag=1.0)
    windy = still.model_copy(update={"wind": True})
    a, _ = simulate(still, 6.0, np.array([5.0, 0.0, 0.0]), terrain.flat)
    b, _ = simulate(windy, 6.0, np.array([5.0, 0.0, 0.0]), terrain.flat)
    assert b[:, 0].mean() - a[:, 0].mean() > 3.0


def test_a_particles_strength_is_continuous_in_time():
    """One slot's strength (0 while the slot waits), sampled every 2 ms over three cycles,
    never jumps. It ramps from 0 over two steps at birth (a particle born at full strength
    popped into view), then falls as remaining life over initial life."""
    p = Particles(count=1, life_min=6, life_max=10, step=0.1)
    ts = np.arange(0.0, 3.0, 0.002)
    s = np.array([(lambda st: float(st[1][0]) if len(st[1]) else 0.0)(simulate(p, t, WIND, terrain.flat))
                  for t in ts])
    assert float(np.abs(np.diff(s)).max()) <= 0.002 / (2 * p.step) + 1e-9
    assert float(s.max()) > 0.7   # and it does reach a real strength
