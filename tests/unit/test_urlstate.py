"""The URL codec: round trips (property-based), canonical form, readable output."""

from __future__ import annotations

import base64
import re
import zlib
from urllib.parse import quote

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from draws import ALL, random_layer
from fogbank.model import presets as P
from fogbank.model.params import FogParams, StillParams
from fogbank.model.urlstate import URLError, canonical, decode, decode_lenient, encode

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@st.composite
def looks(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    base = FogParams.model_validate(P.preset_dict(draw(st.sampled_from(sorted(P.presets())))))
    layers = base.layers if draw(st.booleans()) else [
        random_layer(draw(st.sampled_from(ALL)), rng) for _ in range(draw(st.integers(0, 5)))]
    return StillParams.model_validate({
        **base.model_dump(), "layers": [l.model_dump() for l in layers],
        "camera": {"position": (draw(st.floats(-300, 300)), draw(st.floats(-50, 300)), draw(st.floats(-300, 300))),
                   "yaw": draw(st.floats(-360, 360)), "pitch": draw(st.floats(-89, 89)),
                   "fov": draw(st.floats(10, 120))},
        "time": draw(st.floats(0, 1e6)), "density": draw(st.floats(0, 20)),
        "fog_color": "#%06x" % draw(st.integers(0, 0xFFFFFF)),
        "effects": {"fog_scale": draw(st.sampled_from([1, 2, 4])),
                    "blur": draw(st.sampled_from(["off", "single", "separate"]))},
        "width": draw(st.integers(1, 4096)), "height": draw(st.integers(1, 3000)),
    })


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(looks(), st.sampled_from(sorted(P.presets())))
def test_params_url_params_is_identity(still, base):
    q = encode(still, base)
    value, got_base = decode(q, StillParams)
    assert got_base == base
    assert StillParams.model_validate(value) == still
    assert canonical(q, StillParams) == q   # the encoding is already canonical


@settings(max_examples=100, deadline=None)
@given(looks())
def test_url_params_url_gives_canonical(still):
    q = encode(still)
    # shuffled order, a redundant default, and an explicit version give the same canonical URL
    parts = q.split("&")
    shuffled = "&".join(parts[1:][::-1] + [parts[0]])
    noisy = shuffled + ("&scene=countryside" if "scene=" not in q else "")
    assert canonical(noisy, StillParams) == q


def test_defaults_are_left_out_and_readable():
    assert encode(FogParams.model_validate(P.preset_dict("default"))) == "v=1"
    cam = {**P.preset_dict("default")["camera"], "position": (1, 2, 3), "yaw": 10.5}
    p = FogParams.model_validate({**P.preset_dict("default"), "camera": cam})
    assert encode(p) == "v=1&camera.position=1,2,3&camera.yaw=10.5"
    p = FogParams.model_validate({**P.preset_dict("default"), "fog_color": "#aabbcc",
                                  "layers": [{"kind": "sphere", "radius": 3.5}]})
    assert encode(p) == "v=1&fog_color=aabbcc&layers=1&layers.0.kind=sphere&layers.0.radius=3.5"


def test_same_query_on_page_and_still():
    value, _ = decode("camera.yaw=7&width=640", StillParams)
    assert value["width"] == 640 and value["camera"]["yaw"] == 7.0
    value, _ = decode("camera.yaw=7", FogParams)
    assert "width" not in value


@pytest.mark.parametrize("q", ["%", "a", "layers=x", "layers=100000", "v=2", "layers.0.kind=fog",
                               "camera.yaw=1&camera.yaw=2", "x" * 20000])
def test_malformed(q):
    with pytest.raises(URLError) as exc:
        decode(q)
    assert exc.value.errors and all(e["loc"][0] == "query" for e in exc.value.errors)


def test_presets_round_trip_from_their_own_base():
    for name in P.presets():
        p = FogParams.model_validate(P.preset_dict(name))
        assert encode(p, name) == f"v=1&preset={name}" if name != "default" else encode(p) == "v=1"
        assert FogParams.model_validate(decode(encode(p))[0]) == p


def test_page_keys_are_not_part_of_the_look():
    from fogbank.model.urlstate import view_state, view_suffix
    value, _ = decode("camera.yaw=9&play=0&speed=2", StillParams)
    assert value["camera"]["yaw"] == 9.0
    assert view_state("camera.yaw=9&play=0&speed=2") == {"playing": False, "speed": 2.0}
    assert view_state("play=maybe&speed=fast") == {}
    assert view_suffix(True, 1.0) == "" and view_suffix(False, 0.5) == "&play=0&speed=0.5"


def test_a_counted_layer_starts_homogeneous_and_refuses_fields_of_other_kinds():
    """`layers=1` alone is a look (schemathesis sends it): the item starts as the union's
    first class until `.kind` picks another; a field of another kind is named in the error."""
    from pydantic import ValidationError

    from fogbank.model.params import StillParams
    value, _ = decode("layers=1", StillParams)
    assert StillParams.model_validate(value).layers[0].kind == "homogeneous"
    value, _ = decode("layers=1&layers.0.radius=3", StillParams)
    with pytest.raises(ValidationError) as exc:
        StillParams.model_validate(value)
    assert ("layers", 0, "homogeneous", "radius") in [tuple(e["loc"]) for e in exc.value.errors()]


@pytest.mark.parametrize("text", ["１６", "1_6", " 16", "16 ", "١٢"])
def test_url_numbers_are_ascii_only(text):
    """Python's int() and float() read full-width and Arabic-Indic digits and underscores;
    a look's URL must not have several spellings of one number."""
    from pydantic import ValidationError

    from fogbank.model.params import StillParams
    value, _ = decode("width=" + quote(text), StillParams)
    with pytest.raises(ValidationError) as exc:
        StillParams.model_validate(value)
    assert exc.value.errors()[0]["loc"] == ("width",)


BAD_PARTS = [("bogus.key", "1"), ("density", "abc"), ("density", "99"), ("camera.fov", "500"),
             ("layers.40.density", "1"), ("fog_color", "nope"), ("camera.position", "1e12,0,0")]


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(looks(), st.sampled_from(BAD_PARTS))
def test_a_bad_part_of_a_link_keeps_the_rest(still, bad):
    """A link with one bad key or value gives the look of the link without it, and one
    error that names that key (issue 12: a bad part used to reset the whole look)."""
    key, value = bad
    good = "&".join(p for p in encode(still).split("&") if not p.startswith(key + "="))
    got, errs = decode_lenient(f"{good}&{key}={value}", StillParams)
    assert got == StillParams.model_validate(decode(good, StillParams)[0])
    assert [e["loc"] for e in errs] == [["query", key]]


def test_an_unknown_preset_or_version_keeps_the_rest_of_the_link():
    got, errs = decode_lenient("v=2&preset=nope&camera.yaw=33&density=2")
    assert (got.camera.yaw, got.density) == (33, 2)
    assert got.layers == FogParams.model_validate(P.preset_dict("default")).layers
    assert [e["loc"] for e in errs] == [["query", "v"], ["query", "preset"]]
    assert "default" in errs[1]["msg"] and "biri-fig6" in errs[1]["msg"]


@pytest.mark.parametrize("q", ["x" * 20000, "a=1&&=&b"])
def test_an_unreadable_link_is_refused_whole(q):
    with pytest.raises(URLError):
        decode_lenient(q)


def longest_look(seed: int = 0) -> StillParams:
    from domain import long_look
    return long_look(np.random.default_rng(seed), None, StillParams, "domain")


def test_every_look_has_a_link():
    """The longest look's readable query is within MAX_QUERY (a 16-layer look of 8-term
    cosines was over the old 16384 and could not be linked at all)."""
    from fogbank.model.urlstate import MAX_QUERY
    for seed in range(3):
        look = longest_look(seed)
        q = encode(look)
        assert len(q) <= MAX_QUERY
        assert len(q) > 20000   # it is the long case: 16 layers with every list full
        assert StillParams.model_validate(decode(q, StillParams)[0]) == look


# ---------------------------------------------------------------- compact links


@st.composite
def schema_looks(draw):
    """A look with every field drawn from the params model over its whole range (up to 16
    layers of any kinds, tests/domain.py)."""
    from domain import draw_model
    return draw_model(StillParams, np.random.default_rng(draw(st.integers(0, 2**32 - 1))))


@st.composite
def queries(draw):
    """A readable query of a look (canonical, or shuffled), with the page's keys anywhere."""
    still = draw(st.one_of(looks(), schema_looks()))
    parts = encode(still, draw(st.sampled_from(sorted(P.presets())))).split("&")
    if draw(st.booleans()):
        parts = draw(st.permutations(parts))
    for key, value in (("play", st.sampled_from(["0", "1"])), ("speed", st.sampled_from(["0.5", "2", "-1"]))):
        if draw(st.booleans()):
            parts = list(parts)
            parts.insert(draw(st.integers(0, len(parts))), f"{key}={draw(value)}")
    return "&".join(parts)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(queries())
def test_a_compact_link_reads_as_its_readable_query(q):
    from fogbank.model.urlstate import compact, view_state
    z = compact(q)
    assert z.startswith("z=") and all(p.split("=")[0] in ("z", "play", "speed", "time") for p in z.split("&"))
    assert decode(z, StillParams) == decode(q, StillParams)
    assert decode_lenient(z, StillParams) == decode_lenient(q, StillParams)
    assert view_state(z) == view_state(q)
    assert canonical(z, StillParams) == canonical(q, StillParams)


def test_the_longest_look_has_a_compact_link():
    from fogbank.model.urlstate import MAX_COMPACT, compact
    look = longest_look()
    z = compact(encode(look))
    assert len(z) - len("z=") <= MAX_COMPACT
    assert StillParams.model_validate(decode(z, StillParams)[0]) == look


def _z_error(q, lenient=False):
    with pytest.raises(URLError) as exc:
        (decode_lenient if lenient else decode)(q)
    return exc.value.errors


def _deflate(data: bytes) -> bytes:
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    return c.compress(data) + c.flush()


def _b64(data: bytes) -> str:
    return base64.urlsafe_b64encode(data).rstrip(b"=").decode()


@settings(max_examples=200, deadline=None)
@given(st.text(min_size=1, max_size=200).filter(lambda s: re.search(r"[^A-Za-z0-9_-]", s)))
def test_a_z_that_is_not_base64url_is_named(text):
    for lenient in (False, True):
        errs = _z_error("z=" + quote(text, safe=""), lenient)
        assert [e["loc"] for e in errs] == [["query", "z"]]
        assert "base64url" in errs[0]["msg"]


def _inflates(data: bytes) -> bool:
    """An independent reading of raw deflate: does `data` hold exactly one whole stream?"""
    d = zlib.decompressobj(wbits=-15)
    try:
        d.decompress(data)
    except zlib.error:
        return False
    return d.eof and not d.unused_data


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=300))
def test_a_z_that_is_not_deflate_is_named(data):
    assume(not _inflates(data))
    for lenient in (False, True):
        errs = _z_error("z=" + _b64(data), lenient)
        assert [e["loc"] for e in errs] == [["query", "z"]]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(looks(), st.data())
def test_a_cut_or_padded_z_is_named(still, data):
    raw = _deflate(encode(still).encode())
    cut = raw[:data.draw(st.integers(0, len(raw) - 1))]
    padded = raw + data.draw(st.binary(min_size=1, max_size=8))
    for bad in (cut, padded):
        assert not _inflates(bad)
        assert [e["loc"] for e in _z_error("z=" + _b64(bad))] == [["query", "z"]]


def test_a_zip_bomb_costs_nothing():
    """10 MB deflated into 13k characters of z: refused, naming z, having inflated no
    more than MAX_QUERY + 1 bytes of it."""
    import time

    from fogbank.model.urlstate import MAX_COMPACT, MAX_QUERY
    bomb = _b64(_deflate(b"a" * 10_000_000))
    assert len(bomb) <= MAX_COMPACT
    t0 = time.perf_counter()
    errs = _z_error("z=" + bomb)
    assert time.perf_counter() - t0 < 0.05
    assert [(e["loc"], e["type"]) for e in errs] == [(["query", "z"], "url_too_long")]
    assert f"more than {MAX_QUERY}" in errs[0]["msg"]
    # and a z longer than its bound is not even decoded
    errs = _z_error("z=" + "A" * (MAX_COMPACT + 1))
    assert [(e["loc"], e["type"]) for e in errs] == [(["query", "z"], "url_too_long")]


def test_beside_z_only_the_page_keys_may_stand():
    from fogbank.model.urlstate import compact, view_state
    q = "v=1&camera.yaw=33&density=2&time=4"
    z = compact(q + "&play=0&speed=0.5")
    assert z.split("&")[1:] == ["time=4", "play=0", "speed=0.5"]
    assert view_state(z) == {"playing": False, "speed": 0.5}
    errs = _z_error(z + "&density=3&preset=dusk")
    assert [e["loc"] for e in errs] == [["query", "density"], ["query", "preset"]]
    assert all("beside z" in e["msg"] for e in errs)
    # a lenient reader leaves the stray key out and reads the rest
    got, errs = decode_lenient(z + "&density=3")
    assert got == FogParams.model_validate(decode(q)[0])
    assert [e["loc"] for e in errs] == [["query", "density"]]
    # a time beside z and one inside it: as any key given twice (the last, beside, wins)
    both = f"z={_b64(_deflate(q.encode()))}&time=9"
    assert [e["loc"] for e in _z_error(both)] == [["query", "time"]]
    assert decode_lenient(both)[0].time == 9
    inner = compact(q).split("&")[0]
    assert [e["loc"] for e in _z_error(f"{inner}&{inner}")] == [["query", "z"]]
    # a z inside z, and a z whose text is not UTF-8
    assert [e["loc"] for e in _z_error("z=" + _b64(_deflate(inner.encode())))] == [["query", "z"]]
    assert [e["loc"] for e in _z_error("z=" + _b64(_deflate(b"density=\xff")))] == [["query", "z"]]


def test_long_queries_are_shared_compact():
    from fogbank.model.urlstate import LONG_QUERY, shareable
    short = "v=1&camera.yaw=12&density=2"
    assert shareable(short) == short
    terms = [{"amp": 0.1, "k": [1 / 7, 1, 0], "phase": j / 7} for j in range(8)]
    long = encode(FogParams.model_validate({"layers": [{"kind": "cosine", "terms": terms, "scale": 1 + i / 7}
                                                       for i in range(4)]}))
    assert len(long) > LONG_QUERY
    assert shareable(long).startswith("z=") and decode(shareable(long)) == decode(long)


def test_the_page_compacts_past_the_same_length():
    from fogbank import STATIC_DIR
    from fogbank.model.urlstate import BESIDE_Z, LONG_QUERY
    js = (STATIC_DIR / "links.js").read_text()
    assert re.search(r"export const LONG_QUERY = (\d+);", js)[1] == str(LONG_QUERY)
    assert re.search(r"const BESIDE_Z = new Set\(\[([^\]]*)\]\)", js)[1] == ", ".join(f'"{k}"' for k in BESIDE_Z)


@pytest.mark.parametrize("name", ["default", "biri-fig7", "fischer-smoke"])
def test_a_fields_keys_are_exactly_its_keys_in_the_whole_query(name):
    """encode_field (a camera reply's query, issue 34): the `camera.` keys of the whole
    canonical query, in order, for a preset's camera, a moved one, and the default's."""
    from fogbank.model.urlstate import encode_field
    look = FogParams.model_validate(P.preset_dict(name))
    for cam in (look.camera, look.camera.model_copy(update={"yaw": -7.25, "fov": 44.0}),
                FogParams.model_validate(P.preset_dict("default")).camera):
        new = look.model_copy(update={"camera": cam})
        whole = [kv for kv in encode(new).split("&") if kv.startswith("camera.")]
        part = encode_field(new, "camera")
        assert (part.split("&") if part else []) == whole
