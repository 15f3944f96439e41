"""stream/live.py's parts that need no socket: the tokens beside a look's query, and a watched session's place."""

from fogbank.stream.live import split_live


def test_room_and_live_are_taken_out_of_the_look_query():
    assert split_live("v=1&time=3&room=abcdefghijklmnop1234") == ("v=1&time=3", "abcdefghijklmnop1234", None)
    assert split_live("live=abcdefghijklmnop1234") == ("", None, "abcdefghijklmnop1234")
    assert split_live("") == ("", None, None)


def test_a_room_that_is_no_token_is_dropped_and_a_bad_live_is_kept_to_be_refused():
    # too short, and a character outside URL-safe base64
    assert split_live("time=3&room=short") == ("time=3", None, None)
    assert split_live("room=abcdefghijklmnop%3C") == ("", None, None)
    assert split_live("live=%3Cscript%3E") == ("", None, "%3Cscript%3E")


def test_a_token_given_twice_is_not_read_as_one_of_them():
    """Found by review: nginx routes by the first `live` (and `room`) of a query, and the
    server read the last, so `live=A&live=B` could reach A's replica and join B there. Two
    `live` values come back joined by "&", no token (the viewer is refused); two rooms are
    dropped (the session gets a token of its own when shared)."""
    a, b = "abcdefghijklmnop1234", "qrstuvwxyzABCDEF5678"
    assert split_live(f"live={a}&live={b}") == ("", None, f"{a}&{b}")
    assert split_live(f"time=3&room={a}&room={b}") == ("time=3", None, None)
    assert split_live(f"time=3&room={a}&room={a}") == ("time=3", None, None)


def test_a_watched_session_never_yields_its_place():
    """A presenter of a paused look with viewers (a class listening) renders nothing and
    says nothing, yet is not the session that gives its place to a newcomer; the same
    session unwatched is."""
    from types import SimpleNamespace

    from fogbank.stream.live import Audience
    from fogbank.stream.protocol import parse
    from fogbank.stream.session import Session
    from fogbank.stream.streaming import Client, Streamer
    st = Streamer(workers=None)
    s = Session("a", now=0.0)
    s.apply(parse('{"type": "play", "playing": false}'), 0.0)
    c = Client(s, ws=None, addr="127.0.0.1", now=0.0)
    c.spoke = True
    c.slot = SimpleNamespace(index=0, sessions=1)
    st.clients["a"] = c
    later = 10 * st.settings.yield_after_s
    assert st.idle_for(c, later) == later
    c.audience = Audience(c, "abcdefghijklmnop1234")
    c.audience.viewers["v1"] = SimpleNamespace(id="v1")
    assert st.idle_for(c, later) is None
    c.audience.viewers.clear()
    assert st.idle_for(c, later) == later


def _audience():
    from types import SimpleNamespace

    from fogbank.stream.live import Audience
    from fogbank.stream.session import Session
    presenter = SimpleNamespace(session=Session("p", now=0.0), closed=False)
    return Audience(presenter, "abcdefghijklmnop1234.abcdefghijklmnop")


def test_a_viewer_that_stops_reading_holds_two_frames_whatever_it_acknowledges():
    """A viewer whose socket takes nothing (its writes block) and that acknowledges frames
    it was never given (ack 2^32-1) still has at most two frames queued: the acks past its
    last frame are ignored, and frames not yet written count against its window."""
    import asyncio

    from fogbank.stream.live import Viewer

    class Stuck:   # a socket whose writes never finish
        async def send_text(self, text):
            await asyncio.Event().wait()

        async def send_bytes(self, data):
            await asyncio.Event().wait()

    async def run():
        aud = _audience()
        v = Viewer("v1", aud.session, Stuck(), "127.0.0.1")
        v.start(aud)
        aud.join(v, 0.0)
        for frame in range(1, 41):
            await aud.fan_out(frame, "jpeg", False, b"x" * 50_000, None, 0.0)
            v.ack(2**32 - 1)
            v.ack(frame)
            await asyncio.sleep(0)
        queued = v.queued_frames
        frames = v.frames
        await v.stop()
        return queued, frames
    queued, frames = asyncio.run(run())
    assert queued <= 2
    assert frames <= 3   # the one being written, and two queued


def test_handing_control_over_ends_the_drag_of_whoever_had_it():
    """Control handed over, given back or lost with its viewer mid-drag: the session is no
    longer held in its previews (the new controller never sent the drag's end)."""
    from types import SimpleNamespace
    aud = _audience()
    s = aud.session
    aud.viewers["v1"] = SimpleNamespace(id="v1", codecs=("jpeg",))
    s.interacting = True
    aud.hand("v1")
    assert s.interacting is False
    s.interacting = True   # v1 drags, then leaves
    aud.leave(aud.viewers["v1"])
    assert aud.control is None
    assert s.interacting is False


def _watcher(vid, told=False):
    from types import SimpleNamespace
    return SimpleNamespace(id=vid, codecs=("jpeg",), waiting_key=True, told_codecs=told, closed=False,
                           joined=0.0, room=lambda: True)


def test_viewers_joining_and_leaving_in_a_loop_ask_one_keyframe_a_second():
    """Review finding 5: each join asked the session for a keyframe and applied its codecs
    at once (and a page's first view message asked again, whatever the pace), so viewers
    connecting in a loop forced a keyframe, or a new encoder, on every viewer each time.
    Twenty pages that join, say they decode VP8 and leave, 0.1 s apart over 2 s of a
    playing look, now ask 2 keyframes (the first page's at once)."""
    aud = _audience()
    s = aud.session
    s.playing = True
    asked = 0
    for i in range(20):
        now = 0.1 * i
        v = _watcher(f"v{i}")
        aud.join(v, now)
        aud.set_codecs(v, ("vp8", "jpeg"), now + 0.01)
        asked += s.need_key
        s.need_key = False      # the frame that carried it
        aud.leave(v, now + 0.05)
        asked += s.need_key
        s.need_key = False
    assert asked == 2


def test_a_joining_page_does_not_narrow_the_codecs_before_it_says_what_it_decodes():
    """Review: a new viewer counted as JPEG from its join, so each page joining a VP9
    session turned everyone to JPEG until its view message came, then back: two new
    encoders. It counts once it has said what it decodes, or once it has been silent for
    VIEW_WAIT_S (then as JPEG, at the next frame's settling)."""
    from fogbank.stream.session import VIEW_WAIT_S
    aud = _audience()
    s = aud.session
    s.playing = True
    a = _watcher("a")
    aud.join(a, 0.0)
    aud.set_codecs(a, ("vp09", "jpeg"), 0.01)
    assert s.decoders == frozenset({"vp09", "jpeg"})
    b = _watcher("b")
    aud.join(b, 2.0)
    aud._settle_codecs(2.0 + VIEW_WAIT_S / 2)
    assert s.decoders == frozenset({"vp09", "jpeg"})   # b has not said yet
    aud.set_codecs(b, ("vp09", "vp8", "jpeg"), 2.0 + VIEW_WAIT_S / 2)
    assert s.decoders == frozenset({"vp09", "jpeg"})   # the same set: no new encoder
    c = _watcher("c")                                  # a client that never says
    aud.join(c, 4.0)
    aud._settle_codecs(4.0 + VIEW_WAIT_S + 0.01)
    assert s.decoders == frozenset({"jpeg"})


def test_viewers_never_hold_the_presenters_frames():
    """Review finding 1: a codec change held back on a paused look scheduled the look's
    next frame for when the change was due, which held every frame of the presenter's too
    (a drag's previews, a press of Play) for up to a second. A paused look's frames are
    JPEG, so nothing waits on them: joins, leaves and codec changes on a paused look leave
    the presenter's next frame where it was."""
    import math
    aud = _audience()
    s = aud.session
    s.playing = False
    for i in range(6):
        v = _watcher(f"v{i}")
        aud.join(v, 0.1 * i)
        aud.set_codecs(v, ("vp09", "jpeg") if i % 2 else ("jpeg",), 0.1 * i + 0.01)
        if i % 3 == 2:
            aud.leave(v, 0.1 * i + 0.05)
    assert s.not_before == -math.inf


def test_a_viewers_window_holds_its_own_round_trip():
    """Review finding 3: the presenter's window grew by its round trip and the viewers'
    stayed at two, so a viewer as far away as its presenter skipped frames (and asked
    everyone for keyframes). A viewer's round trip is the least time its frames took to be
    acknowledged: 0.11 s at 30 frames a second holds 3 more frames; none until one is."""
    from fogbank.stream.live import Viewer
    aud = _audience()
    v = Viewer("v1", aud.session, None, "127.0.0.1")
    assert v.window() == 2
    v.inflight[1], v.last_frame = 10.0, 1
    v.ack(1, 10.11)
    assert v.window() == 2 + 3
