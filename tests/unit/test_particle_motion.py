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


def test_a_particle_continued_from_its_last_step_is_the_one_integrated_from_its_birth():
    """The trajectory cache (Trajectories): over layers drawn from the whole schema and
    times that run forward by frames, jump ahead, stand still and go back, every position
    and strength equals, bit for bit, the integration from each particle's birth
    (cache=None); and a frame 1/30 s later integrates a step or two, not the lives again."""
    from fogbank.kinds import particle_motion as pm
    from fogbank.kinds.particles import sample
    rng = np.random.default_rng(11)
    for _ in range(4):
        layer = sample(rng)
        layer = layer.model_copy(update={"life_max": int(rng.integers(layer.life_min, 301)),
                                         "gravity": float(rng.uniform(-9.8, 9.8))})
        cache = pm.Trajectories()
        t = float(rng.uniform(0, 500))
        times = [t + i / 30 for i in range(4)] + [t + 9.0, t + 9.0, t + 2.0, t + 400.0, t + 400.04]
        for ground in (terrain.height, terrain.flat):
            for when in times:
                a = simulate(layer, when, WIND, ground, cache=cache)
                b = simulate(layer, when, WIND, ground, cache=None)
                assert np.array_equal(a[0], b[0]) == True   # noqa: E712
                assert np.array_equal(a[1], b[1]) == True   # noqa: E712


def _count_chains(monkeypatch) -> dict:
    """Count the hash chains simulate draws (a step integrated is one), once `start` is
    called: {"n": the count, "start": a function}."""
    from fogbank.kinds import particle_motion as pm
    calls = {"n": 0}
    real = pm._chain

    def counting(h, *keys):
        calls["n"] += 1
        return real(h, *keys)
    calls["start"] = lambda: monkeypatch.setattr(pm, "_chain", counting)
    return calls


def test_a_frame_later_takes_a_step_or_two_not_the_whole_lives(monkeypatch):
    """Counted, not timed: the steps integrated (hash chains of jitter) for a frame 1/30 s
    after the last, with the cache, against from birth."""
    from fogbank.kinds import particle_motion as pm
    layer = Particles(count=64, life_min=500, life_max=1000, step=0.05, seed=3)
    calls = _count_chains(monkeypatch)
    cache = pm.Trajectories()
    simulate(layer, 100.0, WIND, terrain.height, cache=cache)
    calls["start"]()
    simulate(layer, 100.0 + 1 / 30, WIND, terrain.height, cache=cache)
    continued = calls["n"]
    calls["n"] = 0
    simulate(layer, 100.0 + 1 / 30, WIND, terrain.height, cache=None)
    from_birth = calls["n"]
    # per call: 6 draws at birth (life, cone, box), the particles' own chain, and one
    # chain (three draws) per step integrated
    assert continued <= 7 + 2
    assert from_birth >= 7 + 500


def test_sessions_at_different_times_each_continue_their_own_trajectories(monkeypatch):
    """Two sessions play one look on a worker, each at its own time, frames in turn: each
    frame takes a step or two from its own session's last state. With one state per
    layer, each found the other's later one and integrated every life again (20 ms a
    frame of the default look: a 640x360 stream beside any other session, 26 -> 46 ms)."""
    from fogbank.kinds import particle_motion as pm
    layer = Particles(count=64, life_min=500, life_max=1000, step=0.05, seed=3)
    calls = _count_chains(monkeypatch)
    cache = pm.Trajectories()
    simulate(layer, 100.0, WIND, terrain.height, cache=cache)
    simulate(layer, 200.0, WIND, terrain.height, cache=cache)
    calls["start"]()
    per_frame = []
    for i in range(1, 4):
        for start in (100.0, 200.0):
            calls["n"] = 0
            got = simulate(layer, start + i / 30, WIND, terrain.height, cache=cache)
            per_frame.append(calls["n"])
            want = simulate(layer, start + i / 30, WIND, terrain.height, cache=None)
            assert np.array_equal(got[0], want[0]) == True   # noqa: E712
    # at most one step per particle (each takes its next step at its own moment), against
    # over 500 from birth
    assert max(per_frame) <= 7 + layer.count
