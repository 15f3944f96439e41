"""stream/live.py's parts that need no socket: the tokens beside a look's query."""

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
