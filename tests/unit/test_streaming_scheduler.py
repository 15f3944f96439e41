"""The scheduler's choice of the next frame (stream/streaming.py), with a hand-driven clock
and no worker: a stream that only plays keeps a second frame queued on its worker, a
preview never waits behind one."""

from __future__ import annotations

from types import SimpleNamespace

from fogbank.stream.protocol import parse
from fogbank.stream.session import Session
from fogbank.stream.streaming import QUEUE_MAX_MS, Client, Streamer


SLOT = SimpleNamespace(index=0)


def _client(st, sid, measured_ms=20.0):
    s = Session(sid, now=0.0)
    s.apply(parse('{"type": "view", "width": 64, "height": 64, "fps": 120}'), 0.0)
    s.last_ms = measured_ms   # as Session.measured leaves it after a full frame at its level
    s.last_level = s.refine_level
    c = Client(s, ws=None, addr="127.0.0.1", now=0.0)
    c.slot = SLOT
    st.clients[s.id] = c
    return c


def _streamer(frames_per_worker=1, measured_ms=20.0):
    st = Streamer(workers=None, frames_per_worker=frames_per_worker)
    return st, _client(st, "a", measured_ms)


def _start(st, c, now):
    """What Streamer._run does with a picked client, without the worker."""
    picked, _ = st._pick(now)
    if picked is None:
        return None
    job = picked.session.start_frame(now)
    st.frames[c.slot.index] = st.frames.get(c.slot.index, 0) + 1
    return job


def test_a_playing_stream_keeps_a_second_frame_queued_on_its_worker():
    st, c = _streamer()
    first = _start(st, c, 0.0)
    second = _start(st, c, 0.01)
    assert (first.frame, second.frame) == (1, 2)
    assert _start(st, c, 0.02) is None          # two on the worker: the queue is full
    st.frames[0] -= 1                           # the first is drawn, sent and acknowledged
    c.session.frame_done(first, sent=True)
    c.session.apply(parse('{"type": "ack", "frame": 1}'), 0.03)
    assert _start(st, c, 0.03).frame == 3       # queued while the second is drawn


def test_a_preview_never_waits_behind_another_frame():
    st, c = _streamer()
    c.session.apply(parse('{"type": "interact", "active": true}'), 0.0)
    first = _start(st, c, 0.0)
    assert first.full is False
    assert _start(st, c, 0.01) is None          # one on the worker: a preview waits for it
    st.frames[0] -= 1
    c.session.frame_done(first, sent=True)
    c.session.apply(parse('{"type": "ack", "frame": 1}'), 0.02)
    assert _start(st, c, 0.02).frame == 2


def test_frames_per_worker_sets_the_depth_and_playing_adds_one():
    st, c = _streamer(frames_per_worker=2)
    assert st.queue_room(c, 0.0) == 3
    c.session.apply(parse('{"type": "interact", "active": true}'), 0.0)
    assert st.queue_room(c, 0.0) == 2


def test_no_second_frame_before_frames_are_measured_or_when_they_are_costly():
    for ms in (None, QUEUE_MAX_MS + 1.0):
        st, c = _streamer(measured_ms=ms)
        assert _start(st, c, 0.0) is not None
        assert _start(st, c, 0.01) is None


def test_a_playing_stream_leaves_the_worker_to_a_session_that_previews():
    st, playing = _streamer()
    dragging = _client(st, "b")
    dragging.session.apply(parse('{"type": "interact", "active": true}'), 0.0)
    assert st.queue_room(playing, 0.0) == 1
    dragging.session.apply(parse('{"type": "interact", "active": false}'), 0.0)
    assert st.queue_room(playing, 1.0) == 2


def _serve(st, clients, picks):
    """Start `picks` frames as the scheduler does, the oldest frame on the worker ending
    (drawn, sent, acknowledged) whenever none can start; the frames each session got."""
    now, running, got = 0.0, [], {c.session.id: 0 for c in clients}
    for _ in range(picks):
        while True:
            picked, _ = st._pick(now)
            if picked is not None:
                break
            c, job = running.pop(0)
            st.frames[c.slot.index] -= 1
            c.session.frame_done(job, sent=True)
            c.session.apply(parse(f'{{"type": "ack", "frame": {job.frame}}}'), now)
        running.append((picked, picked.session.start_frame(now)))
        st.frames[picked.slot.index] = st.frames.get(picked.slot.index, 0) + 1
        got[picked.session.id] += 1
        now += 0.01
    return got


def test_a_queued_frame_never_starves_another_session_on_the_worker():
    # a measured playing stream may queue a frame; one not yet measured may not: it kept
    # the worker full with its own frames and the other got none (4 clients: two at 0 fps)
    st, playing = _streamer()
    new = _client(st, "b", measured_ms=None)
    got = _serve(st, [playing, new], 20)
    assert got == {"a": 10, "b": 10}


def test_playing_streams_on_one_worker_take_turns():
    st, a = _streamer()
    others = [_client(st, sid) for sid in "bcd"]
    got = _serve(st, [a, *others], 40)
    assert got == {"a": 10, "b": 10, "c": 10, "d": 10}


def test_a_frames_budget_is_shared_by_the_sessions_that_play_or_preview_on_its_worker():
    """Streamer.sharing counts the sessions on the client's worker that draw frames in
    turn (previewing, or playing with a frame started within SHARE_RECENT_S), the client
    included; not a paused one, nor one on another worker, nor a playing one whose client
    took no frame lately (found by review: it cut the others' budgets for nothing)."""
    from fogbank.stream.streaming import SHARE_RECENT_S
    st, a = _streamer()
    b, paused, dragging, elsewhere, stalled = (_client(st, sid) for sid in "bcdef")
    b.session.last_start = 0.0 - SHARE_RECENT_S / 2
    stalled.session.last_start = 0.0 - 2 * SHARE_RECENT_S
    paused.session.apply(parse('{"type": "play", "playing": false}'), 0.0)
    dragging.session.apply(parse('{"type": "play", "playing": false}'), 0.0)
    dragging.session.apply(parse('{"type": "interact", "active": true}'), 0.0)
    elsewhere.slot = SimpleNamespace(index=1)
    assert st.sharing(a, 0.0) == 3      # a, b and the one dragging
    assert st.sharing(elsewhere, 0.0) == 1
    assert st.sharing(paused, 0.0) == 3   # itself, b and the one dragging: not a, which started no frame


def test_no_second_frame_until_a_full_frame_at_the_level_is_measured():
    """Found by dragging over looks drawn from the schema: a look's first full frames
    compiled programs, so they were not measured, and its cheap previews stood for them;
    two 380 ms frames then ran back to back while a drag's first change waited for both.
    Measured previews, and a full frame that compiled, allow no queued frame; a full
    frame measured at the session's level does."""
    from fogbank.stream.session import INPUT_SETTLE_S
    st, c = _streamer(measured_ms=None)
    s = c.session
    s.last_level = None
    s.apply(parse('{"type": "interact", "active": true}'), 0.0)

    def draw(now, ms, once=False):
        job = _start(st, c, now)
        s.measured(job, ms, now + ms / 1000, once=once)
        st.frames[0] -= 1
        s.frame_done(job, sent=True)
        s.apply(parse('{"type": "ack", "frame": %d}' % job.frame), now + ms / 1000)
        return job
    assert draw(0.0, 39.0).full is False
    s.apply(parse('{"type": "interact", "active": false}'), 0.1)
    t = 0.1 + INPUT_SETTLE_S + 0.05
    assert draw(t, 385.0, once=True).full is True    # compiled: not measured
    assert s.last_ms == 39.0 and st.queue_room(c, t + 0.4) == 1
    job = draw(t + 0.4, 20.0)
    assert job.full is True and job.level == s.refine_level
    assert st.queue_room(c, t + 0.5) == 2


class _Failing:
    """A supervisor whose every frame fails with `exc`."""

    def __init__(self, exc):
        self.exc = exc

    async def call(self, *args, **kwargs):
        raise self.exc


class _Socket:
    def __init__(self):
        self.sent = []

    async def send_text(self, text):
        import json
        self.sent.append(json.loads(text))


def _fail_frames(exc, n):
    """A still session (one full frame owed) whose frames fail with `exc`, `n` times:
    (the messages it was sent, its session after)."""
    import asyncio
    st = Streamer(workers=_Failing(exc))
    c = _client(st, "a")
    c.ws = _Socket()
    c.session.last_full = True   # its frame is drawn: a failed one is owed again only if redone
    c.session.dirty = True

    async def go():
        for i in range(n):
            job = c.session.start_frame(float(i))
            st.frames[0] = 1
            await st._produce(c, job)
    asyncio.run(go())
    return c.ws.sent, c.session


def test_a_frame_lost_to_a_stalled_worker_is_drawn_again_and_the_session_not_paused():
    """Issue 33 finding 2: a deadline on a worker that made no progress paused the session
    and blamed the look."""
    from fogbank.stream.streaming import STALL_RETRIES
    from fogbank.workers.supervisor import DeadlineExceeded
    sent, s = _fail_frames(DeadlineExceeded("stalled", stalled=True, cpu_share=0.0), 1)
    assert [m["type"] for m in sent] == ["error"]
    assert "stalled" in sent[0]["msg"] and "paused" not in sent[0]["msg"]
    assert s.stalled != s.version and s.wants_frame(1.0) is True     # owed again, not paused
    # a worker that seems stalled every time is not killed forever: past STALL_RETRIES in a
    # row the session is paused all the same, and the message says why
    sent, s = _fail_frames(DeadlineExceeded("stalled", stalled=True, cpu_share=0.0), STALL_RETRIES + 1)
    assert s.stalled == s.version and s.wants_frame(9.0) is False
    assert "stalled on" in sent[-1]["msg"] and "paused" in sent[-1]["msg"]


def test_a_frame_that_kept_its_worker_busy_past_the_deadline_pauses_the_look():
    from fogbank.workers.supervisor import DeadlineExceeded
    sent, s = _fail_frames(DeadlineExceeded("took over", stalled=False, cpu_share=1.7), 1)
    assert s.stalled == s.version and s.wants_frame(1.0) is False
    assert "took over" in sent[-1]["msg"] and "1.7 cores" in sent[-1]["msg"]


def _share(cost: dict[str, float], fps: dict[str, int], seconds: float) -> tuple[dict, Streamer]:
    """Sessions playing on one worker, each frame taking cost[id] ms of it, acknowledged at
    once, for `seconds` of a hand-driven clock, as Streamer._run and _produce do them:
    the frames each drew."""
    from fogbank.stream.streaming import fair_charge
    st = Streamer(workers=None, frames_per_worker=1)
    clients = []
    for sid in cost:
        c = _client(st, sid, measured_ms=cost[sid])
        c.session.apply(parse('{"type": "view", "width": 64, "height": 64, "fps": %d}' % fps[sid]), 0.0)
        c.session.apply(parse('{"type": "play", "playing": true}'), 0.0)
        clients.append(c)
    now, drawn = 0.0, {sid: 0 for sid in cost}
    while now < seconds:
        picked, soonest = st._pick(now)
        if picked is None:
            now = soonest if soonest is not None and soonest > now else now + 0.001
            continue
        job = picked.session.start_frame(now, st.sharing(picked, now))
        ms = cost[picked.session.id]
        now += ms / 1000.0
        picked.vtime += fair_charge(ms)
        picked.session.frame_done(job, sent=True)
        picked.session.apply(parse(f'{{"type": "ack", "frame": {job.frame}}}'), now)
        drawn[picked.session.id] += 1
    return drawn, st


def test_sessions_share_a_worker_by_time_not_by_turns():
    """Issue 33 finding 1: streams took turns frame by frame, so a look whose frames take
    500 ms left a 20 ms stream one frame per 520 ms. By time, a frame over FAIR_FRAME_MS
    counting as more than its time: the cheap stream keeps most of the worker, the costly
    look is drawn, slower; and one that comes back from idle does not then take the worker
    for long."""
    from fogbank.stream.streaming import FAIR_SLACK_MS
    drawn, st = _share({"a": 20.0, "b": 500.0}, {"a": 120, "b": 120}, 10.0)
    print("\nframes in 10 s of worker time:", drawn)
    assert drawn["b"] >= 5                                   # the costly look is drawn, slower
    assert drawn["a"] * 20.0 / 10_000.0 >= 0.7                # turns by frame gave 1:1, equal time 0.5
    cheap, costly = st.clients["a"], st.clients["b"]
    # a session idle while the others drew comes back FAIR_SLACK_MS ahead at most
    idle = _client(st, "c")
    idle.session.apply(parse('{"type": "play", "playing": true}'), 10.0)
    st._pick(10.0)
    assert idle.vtime >= min(cheap.vtime, costly.vtime) - FAIR_SLACK_MS - 1e-9


def test_a_stream_keeps_most_of_its_rate_beside_a_costly_view():
    """Issue 33's target, as scripts/fair_share.py measured it: a 30 frames a second
    stream whose frames take 26 ms (0.8 of the worker), beside a view whose frames take
    130 ms (the difference view's cheapest level). Equal time would leave it 0.6 of its
    rate; the worker also went to the costly view in the 7 ms between the stream's frame
    and its next one's due time. It keeps 0.7 at least; two equally costly looks still
    split the worker evenly."""
    alone, _ = _share({"a": 26.0}, {"a": 30}, 10.0)
    beside, _ = _share({"a": 26.0, "b": 130.0}, {"a": 30, "b": 30}, 10.0)
    print(f"\n30 fps stream alone {alone}, beside a 130 ms view {beside}")
    assert beside["a"] >= 0.7 * alone["a"]
    assert beside["b"] >= 5                                   # drawn, slower
    even, _ = _share({"a": 130.0, "b": 130.0}, {"a": 30, "b": 30}, 10.0)
    assert abs(even["a"] - even["b"]) <= 1


def test_a_costly_look_is_not_held_for_long_beside_a_fast_cheap_stream():
    """A stream of 2 ms frames at 60 frames a second is always due within FAIR_WAIT_S: a
    costly look held for it waited, the worker idle, until the stream's share caught up
    with its 500 ms frames' (one frame in 10 s of a worker used 12% of the time). Held at
    most FAIR_HOLD_FRAMES of its frames' time, it is drawn every 2.5 s, and the stream
    keeps 0.7 of its rate."""
    drawn, _ = _share({"a": 2.0, "b": 500.0}, {"a": 60, "b": 30}, 10.0)
    print(f"\n2 ms frames at 60 fps beside 500 ms frames: {drawn}")
    assert drawn["a"] >= 0.7 * 600
    assert drawn["b"] >= 4


class _Pending:
    async def call(self, *args, **kwargs):
        return {"pending": "noise", "render_ms": 0.0, "encode_ms": 0.0}


def test_a_frame_whose_noise_tile_bakes_is_asked_again_shortly_not_sent():
    """A worker whose noise tile for the look is baking on its thread answers at once that
    it is not ready (workers/worker.py frame): nothing is sent, the frame is owed again, and
    not before PENDING_RETRY_S, so that the worker draws other sessions' frames meanwhile."""
    import asyncio
    from fogbank.stream.streaming import PENDING_RETRY_S
    st = Streamer(workers=_Pending())
    c = _client(st, "a")
    c.ws = _Socket()
    c.session.last_full = True
    c.session.dirty = True
    st.clock = lambda: 5.0

    async def go():
        job = c.session.start_frame(5.0)
        st.frames[0] = 1
        await st._produce(c, job)
    asyncio.run(go())
    assert c.ws.sent == [] and c.session.sent == 0 and c.session.making == 0
    assert c.session.wants_frame(5.0) is True
    assert c.session.next_due(5.0) == 5.0 + PENDING_RETRY_S
    assert st.frames[0] == 0


def test_cheap_streams_on_one_worker_are_not_held_for_each_other():
    """Found by review: the hold for a session due soon held any frame, so a stream of
    10 ms frames beside one of 2 ms frames at 60 frames a second drew 12 frames a second
    of its 30 with the worker three quarters idle. Only a frame over FAIR_FRAME_MS that
    would still run when the other is due waits."""
    drawn, _ = _share({"a": 2.0, "b": 10.0}, {"a": 60, "b": 30}, 10.0)
    print(f"\n2 ms at 60 fps beside 10 ms at 30 fps: {drawn}")
    assert drawn["a"] >= 0.95 * 600 and drawn["b"] >= 0.95 * 300
    drawn, _ = _share({"a": 5.0, "b": 8.0}, {"a": 30, "b": 30}, 10.0)
    assert drawn["a"] >= 0.95 * 300 and drawn["b"] >= 0.95 * 300


def test_a_stream_is_not_held_for_a_look_of_like_cost_on_a_loaded_machine():
    """Found in CI's run (a stream beside the 16-layer look kept 0.11 of its rate): on a
    machine loaded by something else, a 640x360 stream's frames took 45-60 ms, over
    FAIR_FRAME_MS, and the costly look's frames, drawn small with their fog held, 15. The
    stream was held for the look's every next frame, the worker idle a third of the time:
    it kept 0.32 of its rate. Held only for frames FAIR_HOLD_RATIO times cheaper than its
    own, the two take turns by time and the worker is never idle while one is due; a
    costly look's 130 ms frames are still held for a 26 ms stream (the test above)."""
    alone, _ = _share({"a": 45.0}, {"a": 30}, 10.0)
    beside, _ = _share({"a": 45.0, "b": 15.0}, {"a": 30, "b": 30}, 10.0)
    print(f"\n45 ms frames alone {alone}, beside 15 ms frames {beside}")
    assert beside["a"] >= 0.6 * alone["a"]                    # 0.32 before
    assert beside["b"] >= 0.5 * 300
    busy = beside["a"] * 45.0 + beside["b"] * 15.0
    assert busy >= 0.95 * 10_000                              # 0.69 before: held, idle
    # and mid-cost looks are still held for a cheap stream (found by review: a hold by
    # cost ratio left a 26 ms stream 0.27 of its rate beside 100 ms frames)
    for look_ms in (60.0, 100.0):
        alone, _ = _share({"a": 26.0}, {"a": 30}, 10.0)
        beside, _ = _share({"a": 26.0, "b": look_ms}, {"a": 30, "b": 30}, 10.0)
        assert beside["a"] >= 0.6 * alone["a"]
