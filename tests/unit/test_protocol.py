"""The socket's message parser: every bad message gets an error that names the problem."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fogbank.stream.protocol import HEADER, MAGIC, ProtocolError, frame_header, parse


def test_valid_messages_parse():
    assert parse('{"type": "ack", "frame": 3}').frame == 3
    assert parse(b'{"type": "play", "playing": false}').playing is False
    assert parse('{"type": "view", "width": 320, "height": 200}').fps == 30
    v = parse('{"type": "view", "show": "optical_depth", "layer": 2}')
    assert (v.show, v.layer) == ("optical_depth", 2)


@pytest.mark.parametrize("text,loc,word", [
    ("{not json", ["message"], "malformed JSON"),
    ("[1, 2]", ["message"], "JSON object"),
    ('{"type": "fly"}', ["message", "type"], "unknown message type 'fly'"),
    ('{"type": "ack"}', ["message", "frame"], "required"),
    ('{"type": "view", "width": 99999}', ["message", "width"], "less than or equal"),
    ('{"type": "speed", "speed": NaN}', ["message", "speed"], "finite"),
    ('{"type": "ack", "frame": 1, "extra": 2}', ["message", "extra"], "not permitted"),
    ('{"type": "view", "show": "normals"}', ["message", "show"], "'transmittance'"),
    ('{"type": "view", "show": "optical_depth", "layer": 16}', ["message", "layer"], "less than 16"),
    (b"\xff\xfe", ["message"], "UTF-8"),
])
def test_bad_messages_name_the_problem(text, loc, word):
    with pytest.raises(ProtocolError) as exc:
        parse(text)
    errs = exc.value.errors
    assert errs[0]["loc"] == loc
    assert word.lower() in errs[0]["msg"].lower()


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.binary(max_size=200), st.text(max_size=200),
                 st.recursive(st.none() | st.booleans() | st.floats() | st.text(max_size=10),
                              lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=6), c, max_size=4),
                              max_leaves=12).map(json.dumps)))
def test_parser_never_raises_anything_else(data):
    try:
        parse(data)
    except ProtocolError as exc:
        assert exc.errors and all(e["loc"][0] == "message" for e in exc.errors)


def test_header_layout():
    h = frame_header(7, 3, 12.5, 10.0, 2.0, 640, 360, 80, 3, 2)
    assert len(h) == HEADER.size == 36
    magic, frame, version, t, r, e, w, hh, q, flags, scale, _ = HEADER.unpack(h)
    assert (magic, frame, version, t, w, hh, q, flags, scale) == (MAGIC, 7, 3, 12.5, 640, 360, 80, 3, 2)
