"""Links that survive length (issue 12, finding 5), in Debian's Chromium against a real
uvicorn server on 127.0.0.1: a 12k-character look opens (before: a black view and an
empty panel), its "Copy link" is the compact link that opens the same look, and a
100k-character link gets the page that explains.

The look each page shows is compared with the server's own reading of the readable
link (urlstate.decode), never with what a page reported."""

from __future__ import annotations

import json
import time
from urllib.parse import parse_qsl, urlsplit

import numpy as np

from domain import long_look
from fogbank.model.params import FogParams
from fogbank.model.urlstate import LONG_QUERY, decode, encode
from fogbank.settings import Settings
from pages import drag_view
from test_page import new_page, wait_frames

# every control of the panel: its path, its kind and what it shows
PANEL = """[...document.querySelectorAll('#controls [data-path]')].map((e) =>
  [e.dataset.path, e.type, e.type === 'checkbox' ? e.checked : e.value])"""


def reading(kind: str, value):
    """A control's value as the look holds it: a number, a bool, a list, or text."""
    if kind == "number":
        return float(value)
    if kind == "text" and isinstance(value, str) and "," in value:
        return [float(x) for x in value.split(",")]
    return value


def assert_shows(page, look: dict) -> None:
    """The page's look is `look`, and so is every control of its panel, each layer's
    included (compared with `look` itself, the reference)."""
    assert page.evaluate("window.fogbank.params") == look
    panel = page.evaluate(PANEL)
    shown, wanted = {}, {}
    for path, kind, value in panel:
        v = look
        for key in path.split("."):
            v = v[int(key)] if isinstance(v, list) else v[key]
        shown[path] = reading(kind, value)
        wanted[path] = v if kind == "checkbox" else reading(kind, ", ".join(map(str, v)) if isinstance(v, list)
                                                             else str(v))
    assert shown == wanted
    assert {p.split(".")[1] for p in shown if p.startswith("layers.")} == {str(i) for i in range(len(look["layers"]))}


def wait_frame(page, timeout: float = 60) -> None:
    """Until a frame is on the canvas (polled: the page's CSP forbids wait_for_function)."""
    deadline = time.monotonic() + timeout
    while int(page.locator("#view").get_attribute("data-frames") or 0) < 1:
        assert time.monotonic() < deadline, "no frame came"
        time.sleep(0.1)


def test_a_long_look_opens_and_copy_link_gives_its_compact_link(server, browser):
    fog = long_look(np.random.default_rng(5), 12000, enabled=1)
    readable = encode(fog)
    assert len(readable) >= 12000
    look = FogParams.model_validate(decode(readable)[0]).model_dump(mode="json")
    sockets, violations = [], []

    def listen(p):
        p.on("websocket", lambda ws: sockets.append(ws.url))
        p.on("console", lambda m: violations.append(m.text) if "Content Security Policy" in m.text else None)
    # under the page's own CSP: the compression and the module loaded on a click are allowed
    page = new_page(browser, f"{server.url}/?{readable}&play=0", bypass_csp=False, before=listen)
    wait_frame(page)
    assert_shows(page, look)
    assert page.locator("#notice").is_hidden()
    # the stream was opened with the compact link, which fits a WebSocket request line
    assert len(sockets) == 1 and "/ws?z=" in sockets[0] and len(sockets[0]) < len(readable) / 1.5
    # the address bar follows the look in its compact form, so it can be copied as it is
    page.wait_for_function("location.search.startsWith('?z=')")
    assert FogParams.model_validate(decode(page.evaluate("location.search.slice(1)"))[0]).model_dump(mode="json") == look
    page.locator("#copy-link").click()
    page.wait_for_selector("#toast:not([hidden])")
    link = page.evaluate("navigator.clipboard.readText()")
    query = urlsplit(link).query
    assert [k for k, _ in parse_qsl(query)] == ["z", "play", "aspect"]   # the page's keys stay readable
    assert len(link) < len(readable) / 1.5
    assert FogParams.model_validate(decode(query)[0]).model_dump(mode="json") == look
    assert page.errors == [] and violations == []
    page.context.close()
    # the compact link opens the same look
    page = new_page(browser, link)
    wait_frames(page, 1)
    assert_shows(page, look)
    assert page.evaluate("window.fogbank.store.get().confirmed.playing") is False
    assert page.errors == []
    page.context.close()


def test_a_short_look_keeps_its_readable_link(server, browser):
    readable = "v=1&time=6&play=0&camera.yaw=20&density=1.5"
    assert len(readable) <= LONG_QUERY
    page = new_page(browser, f"{server.url}/?{readable}")
    wait_frames(page, 1)
    page.locator("#copy-link").click()
    page.wait_for_selector("#toast:not([hidden])")
    link = page.evaluate("navigator.clipboard.readText()")
    stage = page.evaluate("document.getElementById('stage').clientWidth / document.getElementById('stage').clientHeight")
    assert link == f"{page.url}&aspect={round(stage, 3):g}" and "z=" not in link
    page.context.close()


def test_a_100k_link_gets_the_page_that_explains(server, browser):
    target = "/?v=1&density=2&pad=" + "a" * 100_000
    page = browser.new_context().new_page()
    response = page.goto(server.url + target)
    assert response.status == 414
    assert page.locator("h1").inner_text() == "This link is too long"
    limit = Settings().max_url_bytes
    assert page.locator("#length").inner_text() == \
        f"It is {len(target):,} characters long; this server takes links of at most {limit:,} characters."
    assert "Copy link" in page.locator("main").inner_text()
    page.context.close()


def _looks_and_cameras():
    """Looks (presets, another scene, a camera at the default's values) and cameras to put
    in them, as (look, camera) pairs."""
    from fogbank.model import presets as P
    looks = [FogParams.model_validate(P.preset_dict(n)) for n in ("default", "biri-fig7", "fischer-smoke")]
    looks.append(looks[1].model_copy(update={"scene": "calibration"}))
    base_cam = looks[0].camera
    cams = [base_cam, base_cam.model_copy(update={"yaw": 12.5}),
            base_cam.model_copy(update={"position": (1.0, 30.0, -2.5), "pitch": -20.0, "fov": 40.0}),
            looks[1].camera]
    return [(look, cam) for look in looks for cam in cams]


def test_a_camera_reply_is_spliced_into_the_query_as_the_server_writes_it(server, browser):
    """Issue 34, finding 1: a camera message is answered with the camera's keys of the
    canonical query (urlstate.encode_field), not the look; the page splices them into the
    query it holds (links.js withCamera). The reference is the server's encode of the whole
    new look, for looks with and without camera keys, another scene, and a camera back at
    the default's values (no keys at all)."""
    from fogbank.model.urlstate import encode_field
    page = new_page(browser, server.url + "/?v=1")
    cases = []
    for look, cam in _looks_and_cameras():
        new = look.model_copy(update={"camera": cam})
        cases.append([encode(look), encode_field(new, "camera"), encode(new)])
    got = page.evaluate("""async (cases) => {
      const { withCamera } = await import('/static/links.js');
      return cases.map(([q, part]) => withCamera(q, part));
    }""", cases)
    assert got == [want for _, _, want in cases]
    page.close()


def test_orbiting_a_long_look_sends_cameras_not_looks_and_the_address_follows(server, browser):
    """Issue 34, finding 1, in the page: a 16-layer look (its state about 20 KB) dragged;
    every reply the page read during the drag is a camera reply of a few hundred bytes, and
    the address bar's look is the server's canonical encoding of the look confirmed."""
    from fogbank.tools.link import sixteen_layer_query
    page = new_page(browser, server.url + "/?" + sixteen_layer_query())
    wait_frames(page, 2)
    page.evaluate("""() => { window.__texts = [];
      const ws = window.fogbank.stream.ws;
      ws.addEventListener('message', (e) => { if (typeof e.data === 'string') window.__texts.push(e.data); }); }""")
    drag_view(page, -10, 2)
    page.wait_for_function("window.fogbank.store.get().confirmed.params.camera.yaw !== undefined")
    time.sleep(1.0)
    texts = page.evaluate("window.__texts")
    kinds = [json.loads(t)["type"] for t in texts]
    assert kinds.count("camera") >= 3
    assert max(len(t) for t, k in zip(texts, kinds) if k == "camera") < 400
    assert "state" not in kinds
    confirmed = page.evaluate("window.fogbank.store.get().confirmed")
    want = encode(FogParams.model_validate(confirmed["params"]))
    assert confirmed["query"].split("&play")[0] == want
    search = page.evaluate("location.search")
    assert search.startswith("?z=")   # long: the compact form of the same query
    value, _ = decode(search[1:].split("&aspect")[0])
    assert FogParams.model_validate(value) == FogParams.model_validate(confirmed["params"])
    page.close()
