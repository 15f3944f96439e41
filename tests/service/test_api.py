"""REST: stills decode to the right size and are deterministic with ETags; every kind of
bad input gets a 422 naming the field; schema, presets, health."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest
from PIL import Image

from fogbank.model.urlstate import encode
from fogbank.service.api import resolve
from fogbank.model.params import StillParams


def img(resp):
    return np.asarray(Image.open(io.BytesIO(resp.content)).convert("RGB"))


@pytest.mark.parametrize("fmt,mime", [("png", "image/png"), ("jpg", "image/jpeg"), ("webp", "image/webp")])
def test_still_formats_and_size(client, fmt, mime):
    r = client.get(f"/api/still.{fmt}?width=160&height=90")
    assert r.status_code == 200
    assert r.headers["content-type"] == mime
    assert img(r).shape == (90, 160, 3)


def test_still_is_deterministic_with_etag_and_304(client):
    q = "/api/still.png?width=200&height=100&camera.yaw=12&time=3"
    a, b = client.get(q), client.get(q)
    assert a.content == b.content
    assert a.headers["etag"] == b.headers["etag"]
    assert "max-age" in a.headers["cache-control"]
    assert client.get(q, headers={"If-None-Match": a.headers["etag"]}).status_code == 304
    other = client.get("/api/still.png?width=200&height=100&camera.yaw=13&time=3")
    assert other.headers["etag"] != a.headers["etag"]
    # issue 33 finding 9: a weak tag, a list and "*" were ignored (the still sent again)
    tag = a.headers["etag"]
    for header in (f"W/{tag}", f'"nope", {tag}', f'W/"nope" , W/{tag}', "*"):
        assert client.get(q, headers={"If-None-Match": header}).status_code == 304
    for header in ('"nope"', 'W/"nope", "other"', tag[:-2] + '"'):
        assert client.get(q, headers={"If-None-Match": header}).status_code == 200


def test_post_still_matches_get(client):
    body = {"width": 120, "height": 80, "camera": {"yaw": 20.0}, "layers": [{"kind": "sphere"}]}
    get = client.get("/api/still.png?" + encode(resolve(body)))
    post = client.post("/api/still?format=png", json=body)
    assert post.status_code == 200
    assert np.array_equal(img(get), img(post))


def test_a_compact_query_gives_the_still_of_its_readable_query(client):
    from fogbank.model.urlstate import compact, decode
    q = "width=120&height=80&camera.yaw=20&density=1.5&layers=1&layers.0.kind=sphere&time=3"
    readable, small = client.get("/api/still.png?" + q), client.get("/api/still.png?" + compact(q))
    assert (readable.status_code, small.status_code) == (200, 200)
    assert small.headers["etag"] == readable.headers["etag"]
    assert small.content == readable.content
    # the header names the look, readable while short
    header = small.headers["x-fogbank-query"]
    assert StillParams.model_validate(decode(header, StillParams)[0]) == \
        StillParams.model_validate(decode(q, StillParams)[0])
    assert not header.startswith("z=")


def test_url_param_changes_the_picture(client):
    a = img(client.get("/api/still.png?width=160&height=90"))
    b = img(client.get("/api/still.png?width=160&height=90&density=3"))
    assert np.abs(a.astype(int) - b.astype(int)).mean() > 5


BAD_QUERIES = [
    ("layers=1&layers.0.kind=homogeneous&layers.0.density=-1", ["query", "layers", 0, "homogeneous", "density"]),
    ("layers=1&layers.0.kind=cosine&layers.0.c0=0.1", ["query", "layers", 0, "cosine"]),
    ("layers=1&layers.0.kind=polynomial&layers.0.coeffs=-1,0,1", ["query", "layers", 0, "polynomial"]),
    ("camera.yaw=nan", ["query", "camera", "yaw"]),
    ("camera.fov=inf", ["query", "camera", "fov"]),
    ("layers=1&layers.0.kind=fluffy", ["query", "layers.0.kind"]),
    ("width=5000", ["query", "width"]),
    ("width=4096&height=4096&v=1", ["query"]),   # 16.8 Mpx
    ("layers=2&layers.0.kind=particles&layers.0.count=1000&layers.1.kind=particles&layers.1.count=100",
     ["query"]),
    ("a=1&&&=", ["query"]),
    ("camera.zoom=3", ["query", "camera", "zoom"]),
    ("v=9", ["query", "v"]),
    ("preset=nope", ["query", "preset"]),
    ("layers.9.density=1", ["query", "layers.9.density"]),
    ("layers.3.density=1", ["query", "layers", 3, "particles", "density"]),
    ("effects.fog_scale=3", ["query", "effects", "fog_scale"]),
    ("z=not+base64", ["query", "z"]),
    ("z=8wTA&density=2", ["query", "density"]),   # only play, speed and time stand beside z
]


@pytest.mark.parametrize("query,loc", BAD_QUERIES)
def test_bad_queries_get_422_naming_the_field(client, query, loc):
    r = client.get("/api/still.png?" + query)
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert isinstance(detail, list) and detail
    assert any(list(d["loc"])[:len(loc)] == loc for d in detail), detail
    assert all(d["msg"] for d in detail)


def test_too_many_layers(client):
    body = {"layers": [{"kind": "homogeneous"}] * 17}
    r = client.post("/api/still", json=body)
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][:2] == ["body", "layers"]
    assert "16" in r.json()["detail"][0]["msg"]


def test_over_16_megapixels(client):
    r = client.post("/api/still", json={"width": 4096, "height": 3907})
    assert r.status_code == 422
    assert "16 Mpx" in r.json()["detail"][0]["msg"]
    assert StillParams(width=4000, height=4000).width == 4000   # exactly 16 Mpx is allowed


def test_bad_json_bodies(client):
    for body, loc in [({"camera": {"yaw": "north"}}, ["body", "camera", "yaw"]),
                      ({"layers": [{"kind": "sphere", "radius": 0}]}, ["body", "layers", 0, "sphere", "radius"]),
                      ([1, 2], ["body"])]:
        r = client.post("/api/still", json=body)
        assert r.status_code == 422, r.text
        assert any(list(d["loc"])[:len(loc)] == loc for d in r.json()["detail"])
    r = client.post("/api/still", content=b'{"density": NaN}', headers={"content-type": "application/json"})
    assert r.status_code == 422
    r = client.post("/api/still", content=b'{"density": ', headers={"content-type": "application/json"})
    assert r.status_code == 422


def test_transmittance_errors(client):
    ray = {"origin": [0, 0, 0], "direction": [0, 0, 0], "length": 1}
    r = client.post("/api/transmittance", json={"rays": [ray]})
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"] == ["body", "rays", 0, "direction"]
    r = client.post("/api/transmittance", json={"rays": []})
    assert r.status_code == 422
    r = client.post("/api/transmittance", json={"params": {"layers": [{"kind": "x"}]},
                                                "rays": [dict(ray, direction=[1, 0, 0])]})
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][:3] == ["body", "params", "layers"]


def test_renderer_survives_bad_input(client):
    """After a burst of bad requests, a good one still renders."""
    for q, _ in BAD_QUERIES:
        client.get("/api/still.png?" + q)
    assert client.get("/api/still.png?width=64&height=64").status_code == 200


def test_schema_has_ranges_steps_units(client):
    s = client.get("/api/schema").json()
    defs = s["$defs"]
    yaw = defs["Camera"]["properties"]["yaw"]
    assert yaw["minimum"] == -360 and yaw["maximum"] == 360 and yaw["step"] == 0.5 and yaw["unit"] == "deg"
    # the layer union: one branch per registered kind, told apart by `kind`
    from fogbank.kinds import KINDS
    items = s["properties"]["layers"]["items"]
    assert sorted(items["discriminator"]["mapping"]) == sorted(KINDS)
    assert len(items["oneOf"]) == len(KINDS)
    assert s["properties"]["width"]["maximum"] == 4096


def test_presets_and_their_queries_render(client):
    ps = client.get("/api/presets").json()
    names = {p["name"] for p in ps}
    assert {"default", "biri-fig6", "biri-fig7", "biri-fig8", "quilez-spheres", "fischer-fog",
            "fischer-smoke", "perlin-fog", "gawron-distance"} <= names
    for p in ps:
        r = client.get(f"/api/still.jpg?{p['query']}&width=96&height=54")
        assert r.status_code == 200, (p["name"], r.text)


def test_healthz_names_renderer(client):
    h = client.get("/healthz").json()
    assert h["status"] == "ok"
    assert h["renderer"] and h["gl_version"]


def test_docs(client):
    assert client.get("/docs").status_code == 200
    assert "/api/still" in client.get("/openapi.json").json()["paths"]


def test_openapi_describes_the_look(client):
    doc = client.get("/openapi.json").json()
    body = doc["paths"]["/api/still"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert body == {"$ref": "#/components/schemas/StillParams"}
    assert "camera" in doc["components"]["schemas"]["StillParams"]["properties"]
    names = {p["name"] for p in doc["paths"]["/api/still.{fmt}"]["get"]["parameters"]}
    assert {"camera.yaw", "wind.speed", "layers", "effects.fog_scale", "width", "preset"} <= names
    tr = doc["components"]["schemas"]["TransmittanceRequest"]["properties"]["params"]
    assert tr["$ref"] == "#/components/schemas/FogParams"
    assert doc["components"]["schemas"]["Height"]["required"] == ["kind"]


def test_schema_valid_input_is_accepted_and_nothing_beyond_it(client):
    """Found by wiring the look's schema into schemathesis: 177.0 is an integer to JSON
    Schema and was refused; booleans accepted 0/1 and colours beyond the schema's."""
    r = client.post("/api/still?format=jpg", json={"width": 32.0, "height": 24})
    assert r.status_code == 200
    bad = [({"layers": [{"kind": "height", "enabled": 1}]}, ["body", "layers", 0, "height", "enabled"]),
           ({"width": 32.5}, ["body", "width"]),
           ({"fog_color": "red"}, ["body", "fog_color"]),
           ({"layers": [{"density": 0.1}]}, ["body", "layers", 0])]
    for patch, loc in bad:
        r = client.post("/api/still", json={"width": 32, "height": 24, **patch})
        assert (r.status_code, r.json()["detail"][0]["loc"][:len(loc)]) == (422, loc)
    assert client.post("/api/still?format=jpg", json={"width": 32, "height": 24,
                                                      "fog_color": "C5CCD6"}).status_code == 200


def test_a_suggested_layer_suits_the_look_and_an_unknown_kind_is_named(client):
    r = client.post("/api/layers/suggest", json={"kind": "homogeneous", "params": {}})
    assert r.status_code == 200
    layer = r.json()
    assert layer["kind"] == "homogeneous" and 0 < layer["density"] < 0.01
    cam = {"position": [0, 30, 0], "yaw": 90, "pitch": 0}
    r = client.post("/api/layers/suggest", json={"kind": "sphere", "params": {"camera": cam}})
    assert r.status_code == 200 and r.json()["center"][0] > 10     # in front of a camera facing +x
    r = client.post("/api/layers/suggest", json={"kind": "fog", "params": {}})
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][-1] == "kind"
    r = client.post("/api/layers/suggest", json={"kind": "box", "params": {"density": 99}})
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][-1] == "density"


def test_the_plot_and_profile_endpoints_answer_and_name_bad_fields(client):
    r = client.post("/api/plot/ray", json={"params": {"scene": "calibration"}, "x": 10, "y": 5,
                                           "width": 64, "height": 36})
    assert r.status_code == 200
    body = r.json()
    assert len(body["s"]) == len(body["T"]) and body["hit"] in ("ground", "sky")
    r = client.post("/api/plot/ray", json={"x": 64, "y": 5, "width": 64, "height": 36})
    assert r.status_code == 422 and "outside the 64x36 view" in r.json()["detail"][0]["msg"]
    r = client.post("/api/plot/ray", json={"params": {"density": -1}, "x": 1, "y": 1, "width": 64, "height": 36})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][:3] == ["body", "params", "density"]
    r = client.post("/api/layers/profile", json={"layer": {"kind": "polynomial"}, "points": [1, 1, 0.5, 1, 1]})
    assert r.status_code == 200 and len(r.json()["fitted"]["coeffs"]) == 5
    r = client.post("/api/layers/profile", json={"layer": {"kind": "height"}})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][:2] == ["body", "layer"]
    assert "'polynomial'" in r.json()["detail"][0]["msg"] and "'cosine'" in r.json()["detail"][0]["msg"]
    r = client.post("/api/layers/profile", json={"layer": {"kind": "polynomial"}, "points": [1, 2]})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "points"]
    r = client.post("/api/layers/profile", json={"layer": {"kind": "cosine", "c0": -1}})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][-1] == "c0"


def test_a_costly_ray_plot_is_refused_and_an_unused_noise_tile_is_not_baked(client):
    """A plot follows the cursor: a look whose plot is estimated over 2 s (16 particle
    layers of long lives and short steps) is refused naming what costs; a look with no
    layer sampling the noise tile does not bake one (a 128^3 tile of 6 octaves took 12 s
    and 400 MB in the web process)."""
    heavy = {"kind": "particles", "count": 64, "life_min": 1000, "life_max": 1000, "step": 0.00501}
    r = client.post("/api/plot/ray", json={"params": {"layers": [heavy] * 16}, "x": 5, "y": 5,
                                           "width": 16, "height": 16})
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["type"] == "cost" and err["loc"] == ["body", "params"] and "particle simulation" in err["msg"]
    t0 = time.monotonic()
    r = client.post("/api/plot/ray", json={"params": {"layers": [], "noise": {"size": 128, "octaves": 6, "blur": 8,
                                                                               "seed": 13}},
                                           "x": 5, "y": 5, "width": 16, "height": 16})
    assert r.status_code == 200 and time.monotonic() - t0 < 2.0
