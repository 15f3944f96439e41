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
