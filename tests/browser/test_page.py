"""The page in a real browser: Playwright driving Debian's Chromium against a real
uvicorn server on 127.0.0.1 (started as its own process, stopped by its PID).

Screenshots go to out/screenshots/ (ignored by git)."""

from __future__ import annotations

import io
import json
import re
import time
import urllib.request
from urllib.parse import parse_qs, urlsplit
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pages import (PANEL, canvas_pixels, drag_view, new_page, panel_and_state, shown_version, wait_frames,
                   wait_full_frame_of_current_version, wait_quiet, _at, _read, _shown)
from servers import Server

SHOTS = Path(__file__).resolve().parents[2] / "out" / "screenshots"


def test_page_loads_and_frames_arrive(server, browser):
    page = new_page(browser, server.url + "/")
    wait_frames(page, 5)
    # the overlay names the GL renderer the server reports
    with urllib.request.urlopen(server.url + "/healthz") as r:
        renderer = json.loads(r.read())["renderer"]
    assert page.locator("#stat-renderer").inner_text() == renderer
    # "reduced" quotes the stream's budgets as the server has them (a copy in the page went stale)
    from fogbank.stream.session import PLAY_BUDGET_MS, REFINE_BUDGET_MS
    title = page.locator("#stat-reduced").get_attribute("title")
    assert f"({REFINE_BUDGET_MS / 1000:g} s paused, {PLAY_BUDGET_MS / 1000:g} s while time runs)" in title
    page.wait_for_function("!document.getElementById('stat-fps').textContent.startsWith('0.0')")
    # controls come from the schema, with labels
    assert page.locator("[data-path='density']").count() == 1
    assert page.locator("label[for]").count() > 10
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SHOTS / "page.png"))
    assert page.errors == []
    page.context.close()


def test_page_runs_under_its_csp(server, browser):
    page = new_page(browser, server.url + "/", bypass_csp=False)
    violations = []
    page.on("console", lambda m: violations.append(m.text) if "Content Security Policy" in m.text else None)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if int(page.locator("#view").get_attribute("data-frames") or 0) >= 3:
            break
        time.sleep(0.2)
    assert int(page.locator("#view").get_attribute("data-frames") or 0) >= 3
    assert violations == [] and page.errors == []
    with urllib.request.urlopen(server.url + "/") as r:
        csp = r.headers["Content-Security-Policy"]
    assert "script-src 'self'" in csp and "unsafe-inline" not in csp and "unsafe-eval" not in csp
    # issue 33 finding 9: connect-src allowed ws: and wss: to any host; 'self' alone carries
    # the page's own stream (above) and refuses a socket to another host
    assert "connect-src 'self';" in csp and " ws:" not in csp and " wss:" not in csp
    page.evaluate("() => { try { new WebSocket('ws://127.0.0.2:9/') } catch (e) { return e.name } }")
    deadline = time.monotonic() + 5
    while not violations and time.monotonic() < deadline:
        time.sleep(0.1)
    assert any("127.0.0.2" in v and "connect-src" in v for v in violations)
    page.context.close()


def test_density_control_changes_picture_and_url(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=4&play=0")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    before, v0 = canvas_pixels(page), shown_version(page)
    page.locator("[data-path='density']").fill("3")
    page.locator("[data-path='density']").press("Enter")
    page.wait_for_function("location.search.includes('density=3')")
    # the stream settled (in one full suite a preview was on the canvas 0.3 s after the
    # full frame), then its last frame is the new look's, in full
    wait_quiet(page)
    wait_full_frame_of_current_version(page, newer_than=v0)
    after = canvas_pixels(page)
    assert after.shape == before.shape
    assert np.abs(after - before).mean() > 4
    assert page.errors == []
    page.context.close()


def test_copied_url_gives_the_same_picture_as_the_still(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=6&play=0&camera.yaw=20&density=1.5")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    page.locator("#copy-link").click()
    link = page.evaluate("navigator.clipboard.readText()")
    assert link.startswith(page.url + "&aspect=") and "camera.yaw=20" in link and "play=0" in link
    page.context.close()

    fresh = new_page(browser, link)
    wait_frames(fresh, 1)
    wait_full_frame_of_current_version(fresh)
    shown = canvas_pixels(fresh)
    h, w = shown.shape[:2]
    query = link.split("?", 1)[1]
    with urllib.request.urlopen(f"{server.url}/api/still.png?{query}&width={w}&height={h}", timeout=60) as r:
        still = np.asarray(Image.open(io.BytesIO(r.read())).convert("RGB")).astype(int)
    diff = np.abs(shown - still)
    # the stream is JPEG (quality 80): small differences, none structural
    assert diff.mean() < 2.5
    assert np.percentile(diff, 99) < 24
    fresh.context.close()


def test_dragging_the_view_moves_the_camera(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=3&play=0")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    before, v0 = canvas_pixels(page), shown_version(page)
    drag_view(page, -12, 2)
    page.wait_for_function("location.search.includes('camera.yaw=')")
    yaw = float(page.evaluate("new URLSearchParams(location.search).get('camera.yaw')"))
    assert yaw != 5.0
    # the page sends the drag's last camera once the server took the one before: until it
    # is quiet, a full frame of a confirmed version can still give way to a preview
    wait_quiet(page)
    wait_full_frame_of_current_version(page, newer_than=v0)
    assert np.abs(canvas_pixels(page) - before).mean() > 3
    # the keyboard flies too
    page.locator("#view").focus()
    page.keyboard.down("w")
    time.sleep(0.4)
    page.keyboard.up("w")
    page.wait_for_function("location.search.includes('camera.position=')")
    page.context.close()


def test_page_reconnects_after_the_server_restarts(browser):
    s = Server().start()
    try:
        page = new_page(browser, s.url + "/?v=1&camera.yaw=45")   # not the default's yaw
        rooms = []
        page.on("websocket", lambda ws: rooms.append(parse_qs(urlsplit(ws.url).query).get("room", [None])[0]))
        page.reload()
        wait_frames(page, 3)
        s.stop()
        page.wait_for_selector("#banner:not([hidden])", timeout=20000)
        assert "reconnecting" in page.locator("#banner").inner_text().lower()
        # the overlay says nothing it cannot know (its fps went stale before)
        page.wait_for_function("document.getElementById('stat-fps').textContent === '–'")
        # an edit made while away is kept (issue 12, finding 8)
        page.locator("[data-path='density']").fill("1.7")
        page.locator("[data-path='density']").press("Enter")
        page.wait_for_function("window.fogbank.store.get().unsent?.density === 1.7")
        before = int(page.evaluate("document.getElementById('view').dataset.frames"))
        s.start()
        back = time.monotonic()
        page.wait_for_selector("#banner[hidden]", state="attached", timeout=30000)
        # back within 2 s of the server's return (the retry interval is at most 1 s)
        assert time.monotonic() - back <= 2.0
        wait_frames(page, before + 3)
        assert "camera.yaw=45" in page.url   # the same look, from the URL
        # a page that shares nothing tries each time with a fresh room (issue 34 review
        # finding 2: a load balancer hashing by room kept sending it to the replica that had
        # gone): every connection's room is its own
        assert len(rooms) >= 2 and None not in rooms
        assert len(set(rooms)) == len(rooms)
        page.wait_for_function("window.fogbank.store.get().confirmed.params.density === 1.7")
        assert page.locator("[data-path='density']").input_value() == "1.7"
        # the whole panel shows the look the new session confirmed
        assert page.evaluate("window.fogbank.store.get().params") == \
            page.evaluate("window.fogbank.store.get().confirmed.params")
        shown, expected = panel_and_state(page)
        assert shown == expected
        page.context.close()
    finally:
        s.stop()


def test_phone_landscape_layout(server, browser):
    ctx = browser.new_context(viewport={"width": 844, "height": 390}, is_mobile=True, has_touch=True,
                              bypass_csp=True)
    page = ctx.new_page()
    page.goto(server.url + "/")
    wait_frames(page, 2)
    view = page.locator("#view").bounding_box()
    assert view["width"] >= 800 and view["height"] >= 300          # the view gets the screen
    assert not page.locator("#panel").is_visible()                 # the panel starts folded
    page.locator("#toggle-panel").click()
    assert page.locator("#panel").is_visible()
    assert page.locator("[data-path='density']").is_visible()
    ctx.close()


def test_controls_are_keyboard_reachable_and_labelled(server, browser):
    page = new_page(browser, server.url + "/")
    wait_frames(page, 1)
    unlabelled = page.evaluate("""[...document.querySelectorAll('#controls input, #controls select')]
        .filter(e => e.type !== 'range' && e.tabIndex >= 0)
        .filter(e => !(e.labels && e.labels.length) && !e.getAttribute('aria-label')).length""")
    assert unlabelled == 0
    page.locator("#preset").focus()
    for _ in range(12):
        page.keyboard.press("Tab")
    assert page.evaluate("document.activeElement.tagName") in ("BUTTON", "SELECT", "INPUT", "SUMMARY")
    page.context.close()


def test_a_quiet_page_is_closed_by_the_server_says_why_and_resumes_on_input(browser):
    srv = Server(env={"FOGBANK_IDLE_TIMEOUT_S": "2"}).start()
    try:
        page = new_page(browser, srv.url + "/?v=1&play=0&time=3")
        wait_frames(page, 1)
        page.wait_for_selector("#banner:not([hidden])", timeout=15000)
        text = page.inner_text("#banner")
        assert "idle" in text and "resume" in text
        frames = int(page.locator("#view").get_attribute("data-frames"))
        page.mouse.click(640, 360)
        wait_frames(page, frames + 1)
        assert page.locator("#banner").is_hidden()
        page.context.close()
    finally:
        srv.stop()


# Two JPEG frames made in the page (an older red one, then a newer blue one) handed to the
# stream as if they came over the socket, with the older one's decode held back until the
# newer one is drawn: the canvas must end up blue, the stale bitmap closed, not drawn.
OUT_OF_ORDER_DECODES = """async () => {
  const stream = window.fogbank.stream;
  async function frame(color, time) {
    const c = new OffscreenCanvas(64, 36);
    const g = c.getContext("2d");
    g.fillStyle = color;
    g.fillRect(0, 0, 64, 36);
    const jpeg = new Uint8Array(await (await c.convertToBlob({ type: "image/jpeg", quality: 0.95 })).arrayBuffer());
    const buf = new ArrayBuffer(36 + jpeg.length);
    const v = new DataView(buf);
    [..."FBK1"].forEach((ch, i) => v.setUint8(i, ch.charCodeAt(0)));
    v.setUint32(4, 0, true);                        // frame id 0: its ack changes nothing
    v.setUint32(8, window.fogbank.version, true);
    v.setFloat64(12, time, true);
    v.setUint16(28, 64, true);
    v.setUint16(30, 36, true);
    v.setUint8(32, 95);
    v.setUint8(33, 1);
    new Uint8Array(buf, 36).set(jpeg);
    return buf;
  }
  const older = await frame("#ff0000", 1), newer = await frame("#0000ff", 2);
  const real = stream.decode, bitmaps = [];
  let release;
  const held = new Promise((r) => { release = r; });
  let calls = 0;
  stream.decode = async (blob) => {
    const n = calls++;
    const bitmap = await real(blob);
    bitmaps[n] = bitmap;
    if (n === 0) await held;   // the older frame's decode ends last
    return bitmap;
  };
  const drawnBefore = window.fogbank.store.get().frames;
  try {
    const first = stream.onMessage({ data: older });
    const second = stream.onMessage({ data: newer });
    await second;
    release();
    await first;
  } finally {
    stream.decode = real;
  }
  return { closed: bitmaps.map((b) => b.width === 0), drawn: window.fogbank.store.get().frames - drawnBefore,
           time: window.fogbank.store.get().lastFrame.time,
           shown: document.getElementById("time-out").textContent };
}"""


def test_a_frame_decoded_late_never_draws_over_a_newer_one(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=3&play=0")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    wait_quiet(page)   # paused and settled: the server sends nothing more
    out = page.evaluate(OUT_OF_ORDER_DECODES)
    px = canvas_pixels(page)
    assert px.shape[:2] == (36, 64)
    red, blue = px[..., 0].mean(), px[..., 2].mean()
    assert blue > 200 and red < 60, (red, blue)           # the newer frame is on the canvas
    assert out["closed"] == [True, True]                  # the stale bitmap was closed too
    assert out["drawn"] == 1 and out["time"] == 2 and out["shown"] == "2.0 s"
    assert page.errors == []
    page.context.close()


def test_the_store_is_the_one_source_of_the_pages_state(server, browser):
    received = []

    def listen(page):
        page.on("websocket", lambda ws: ws.on(
            "framereceived", lambda m: received.append(json.loads(m)) if isinstance(m, str) else None))

    page = new_page(browser, server.url + "/?v=1&time=3", before=listen)
    wait_frames(page, 1)
    # a preset switch
    page.select_option("#preset", "quilez-spheres")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.layers.length === 3"
                           " && document.getElementById('preset').value === 'quilez-spheres'")
    page.wait_for_selector("[data-path='layers.2.radius']", state="attached")
    # a typed edit
    page.locator("[data-path='density']").fill("2.5")
    page.locator("[data-path='density']").press("Enter")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.density === 2.5")
    # a pause
    page.locator("#play").click()
    page.wait_for_function("window.fogbank.store.get().confirmed.playing === false")
    wait_full_frame_of_current_version(page)
    wait_quiet(page)

    state = page.evaluate("window.fogbank.store.get()")
    last = [m for m in received if m["type"] == "state"][-1]
    # (how many changes the reply answers is the reply's, not the look's)
    confirmed = {k: v for k, v in last.items() if k not in ("type", "answers")}
    # what the server last confirmed
    assert state["confirmed"] == confirmed
    assert state["params"] == confirmed["params"]
    assert page.evaluate("window.fogbank.params") == state["params"]
    assert page.evaluate("window.fogbank.version") == confirmed["version"]
    assert state["params"]["density"] == 2.5 and len(state["params"]["layers"]) == 3
    # what the panel and the toolbar show
    panel = page.evaluate(PANEL)
    assert len(panel) > 20
    shown = {path: _read(kind, raw) for path, kind, raw in panel}
    expected = {path: _shown(kind, _at(state["params"], path)) for path, kind, _ in panel}
    assert shown == expected
    assert page.locator("#play").inner_text() == "Play" and state["confirmed"]["playing"] is False
    assert page.locator("#preset").input_value() == ""     # the typed edit made it a custom look
    assert page.evaluate("location.search.slice(1)") == confirmed["query"]
    # nothing else writes the state: it is frozen, and app.js keeps no module-level variables
    assert page.evaluate("Object.isFrozen(window.fogbank.store.get())")
    with urllib.request.urlopen(server.url + "/static/app.js") as r:
        app = r.read().decode()
    assert re.findall(r"^(?:let|var)\s+\w+", app, re.M) == []
    assert page.errors == []
    page.context.close()


def test_the_panel_follows_the_look_through_drags_edits_presets_and_pauses(server, browser):
    """Issue 12, finding 1: the camera fields follow a drag; editing one camera field keeps
    the dragged values of the others; a preset switch while a number field has focus shows
    the new preset's layers; a pause keeps the preset's name."""
    page = new_page(browser, server.url + "/?v=1&time=3&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    page.locator("summary", has_text="camera").first.click()   # open the camera group
    start = page.evaluate("window.fogbank.store.get().confirmed.params.camera")
    # 1. a drag: the camera fields follow it
    drag_view(page, -12, 3)
    wait_quiet(page)
    dragged = page.evaluate("window.fogbank.store.get().confirmed.params.camera")
    assert dragged["yaw"] != start["yaw"] and dragged["pitch"] != start["pitch"]
    shown, expected = panel_and_state(page)
    assert shown["camera.yaw"] == dragged["yaw"]
    assert shown == expected
    # 2. one position field typed: the others keep the dragged camera
    page.locator("[data-path='camera.position.0']").fill("12.5")
    page.locator("[data-path='camera.position.0']").press("Enter")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.camera.position[0] === 12.5")
    cam = page.evaluate("window.fogbank.store.get().confirmed.params.camera")
    assert cam["position"][1:] == dragged["position"][1:]
    assert (cam["yaw"], cam["pitch"], cam["fov"]) == (dragged["yaw"], dragged["pitch"], dragged["fov"])
    # 3. a preset switch while a number field has focus: the new preset's layers
    page.locator("[data-path='density']").click()
    page.select_option("#preset", "quilez-spheres")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.layers.length === 3")
    page.wait_for_selector("[data-path='layers.2.radius']", state="attached")   # a preset plays on
    shown, expected = panel_and_state(page)
    assert shown == expected
    # 4. a pause: the paused time goes into the link, and the preset keeps its name
    assert page.evaluate("window.fogbank.store.get().confirmed.playing") is True
    wait_frames(page, page.evaluate("window.fogbank.store.get().frames") + 3)
    page.locator("#play").click()
    page.wait_for_function("window.fogbank.store.get().confirmed.playing === false")
    assert "time=" in page.evaluate("window.fogbank.store.get().confirmed.query")
    assert page.locator("#preset").input_value() == "quilez-spheres"
    shown, expected = panel_and_state(page)
    assert shown == expected
    assert page.errors == []
    page.context.close()


def test_a_link_with_bad_parts_keeps_the_rest_and_says_what_was_left_out(server, browser):
    """Issue 12, finding 5: a bad key or value used to reset the whole look, rewrite the
    address bar and say so for 4 s. Now the rest of the look is shown, a notice that stays
    names each part left out, and the link as given can still be copied."""
    given = server.url + "/?v=1&camera.yaw=33&density=abc&bogus=1&preset=biri-fig7"
    page = new_page(browser, given)
    wait_frames(page, 1)
    page.wait_for_selector("#notice:not([hidden])")
    confirmed = page.evaluate("window.fogbank.store.get().confirmed")
    assert confirmed["params"]["camera"]["yaw"] == 33
    assert page.locator("#preset").input_value() == ""          # biri-fig7, turned: a custom look
    from fogbank.model.presets import preset_dict
    fig7 = preset_dict("biri-fig7")
    assert [l["kind"] for l in confirmed["params"]["layers"]] == [l["kind"] for l in fig7["layers"]]
    assert "camera.yaw=33" in confirmed["query"] and "bogus" not in confirmed["query"]
    text = page.locator("#notice-text").inner_text()
    assert "density" in text and "bogus" in text
    time.sleep(5)
    assert page.locator("#notice").is_visible()                 # it stays until dismissed
    page.locator("#copy-original").click()
    assert page.evaluate("navigator.clipboard.readText()") == given
    page.locator("#notice-close").click()
    assert not page.locator("#notice").is_visible()
    assert page.errors == []
    page.context.close()


@pytest.mark.parametrize("w,h", [(1024, 768), (1280, 800), (1920, 1080), (844, 390)])
def test_the_toolbar_fits_and_its_export_menu_opens(server, browser, w, h):
    """Issue 12, finding 6: "Download still" was clipped at 1280 px and off-screen at
    1024; on a phone only the preset menu showed; the time scrubber was 57 px wide. Every
    toolbar control lies inside the window at these sizes, the scrubber is wide, and the
    export menu (stream quality, still size, download) opens inside the window."""
    ctx = browser.new_context(viewport={"width": w, "height": h}, bypass_csp=True,
                              **({"is_mobile": True, "has_touch": True} if h < 500 else {}))
    page = ctx.new_page()
    page.goto(server.url + "/")
    wait_frames(page, 1)
    ids = ["toggle-panel", "preset", "play", "speed", "time", "copy-link", "share-live"]
    for i in ids + ["more"]:
        box = page.locator(f"#{i}").bounding_box()
        assert box is not None and page.locator(f"#{i}").is_visible()
        assert box["x"] >= 0 and box["x"] + box["width"] <= w, (i, box)
    assert page.locator("#time").bounding_box()["width"] >= (120 if w < 900 else 200)
    page.locator("#more > summary").click()
    for i in ["stream-size", "still-size", "download"]:
        box = page.locator(f"#{i}").bounding_box()
        assert page.locator(f"#{i}").is_visible()
        assert box["x"] >= 0 and box["x"] + box["width"] <= w and box["y"] + box["height"] <= h, (i, box)
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SHOTS / f"toolbar-{w}x{h}.png"))
    ctx.close()


def test_what_you_share_and_download_is_what_you_see(server, browser):
    """Issue 12, finding 7: a link copied while playing carried the last seek time, and the
    download was 16:9 whatever the view. The copied link carries the time on screen, and
    the still defaults to the view's own shape."""
    ctx = browser.new_context(viewport={"width": 1000, "height": 900}, bypass_csp=True, accept_downloads=True)
    ctx.grant_permissions(["clipboard-read", "clipboard-write"], origin=server.url)
    page = ctx.new_page()
    page.goto(server.url + "/?v=1&time=3")
    wait_frames(page, 1)
    page.wait_for_function("window.fogbank.store.get().lastFrame && window.fogbank.store.get().lastFrame.time > 5")
    page.locator("#copy-link").click()
    now = page.evaluate("window.fogbank.store.get().lastFrame.time")
    link = page.evaluate("navigator.clipboard.readText()")
    t = float(re.search(r"[?&]time=([0-9.]+)", link).group(1))
    assert now - 1.0 <= t <= now + 0.01 and t > 5
    # the still: the view's aspect
    stage = page.evaluate("[document.getElementById('stage').clientWidth, document.getElementById('stage').clientHeight]")
    page.locator("#more > summary").click()
    with page.expect_download() as d:
        page.locator("#download").click()
    m = re.search(r"fogbank-(\d+)x(\d+)\.png", d.value.suggested_filename)
    w, h = int(m.group(1)), int(m.group(2))
    assert max(w, h) == 1920
    assert abs(w / h - stage[0] / stage[1]) <= 0.01
    # the link carries the framing: opened in a window of another shape, the view keeps
    # the link's aspect (letterboxed), and so does its download, until "Fit to window"
    aspect = float(re.search(r"[?&]aspect=([0-9.]+)", link).group(1))
    assert abs(aspect - stage[0] / stage[1]) <= 0.002
    ctx.close()
    ctx = browser.new_context(viewport={"width": 1500, "height": 600}, bypass_csp=True, accept_downloads=True)
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(link.replace("play=1", "play=0") + ("&play=0" if "play=" not in link else ""))
    wait_frames(page, 1)
    assert page.locator("#framing").is_visible()
    page.wait_for_function("(a) => { const c = document.getElementById('view');"
                           " return Math.abs(c.width / c.height - a) < 0.01; }", arg=aspect)
    assert f"aspect={aspect:g}" in page.evaluate("location.search")
    page.locator("#more > summary").click()
    with page.expect_download() as d:
        page.locator("#download").click()
    m = re.search(r"fogbank-(\d+)x(\d+)\.png", d.value.suggested_filename)
    assert abs(int(m.group(1)) / int(m.group(2)) - aspect) <= 0.01
    page.locator("#more > summary").click()
    page.locator("#fit-window").click()
    stage = page.evaluate("[document.getElementById('stage').clientWidth, document.getElementById('stage').clientHeight]")
    page.wait_for_function("(a) => { const c = document.getElementById('view');"
                           " return Math.abs(c.width / c.height - a) < 0.01; }", arg=min(3, stage[0] / stage[1]))
    assert not page.locator("#framing").is_visible()
    assert "aspect=" not in page.evaluate("location.search")
    assert errors == []
    ctx.close()


def test_adding_layers_counts_every_click_opens_them_and_never_whites_out(server, browser):
    """Issue 12, finding 4: five quick clicks on "Add layer" added three layers, each new
    layer opened collapsed, and its defaults whited out the view. Every click now adds a
    layer, the new ones open, and each is the server's suggestion for the look (thin enough:
    tests/gl/test_suggest.py)."""
    page = new_page(browser, server.url + "/?v=1&time=3&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    n0 = page.evaluate("window.fogbank.store.get().confirmed.params.layers.length")
    add = page.locator("fieldset.list .add").filter(has=page.get_by_role("button", name="Add layer"))
    add.locator("select").select_option("homogeneous")
    for _ in range(5):
        add.get_by_role("button", name="Add layer").click()
    page.wait_for_function(f"window.fogbank.store.get().confirmed.params.layers.length === {n0 + 5}")
    layers = page.evaluate("window.fogbank.store.get().confirmed.params.layers")
    assert [l["kind"] for l in layers[n0:]] == ["homogeneous"] * 5
    assert all(l["density"] < 0.01 for l in layers[n0:])      # the bare default is 0.01/m
    page.wait_for_selector(f"[data-path='layers.{n0 + 4}.density']", state="visible")
    assert page.locator("details.item[open]").count() >= 5
    assert page.errors == []
    page.context.close()


@pytest.mark.parametrize("w,h,dpr", [(600, 360, 2), (1920, 1080, 2)])
def test_the_stream_follows_the_canvas_times_its_pixel_ratio_up_to_a_cap(server, browser, w, h, dpr):
    """Finding 7: the 540p stream was soft on large screens. By default the stream has the
    canvas's device pixels (CSS size x devicePixelRatio), scaled down to 1280x720's pixels
    at most, in the canvas's shape."""
    ctx = browser.new_context(viewport={"width": w, "height": h}, device_scale_factor=dpr, bypass_csp=True)
    page = ctx.new_page()
    page.goto(server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    if page.locator("#panel").is_visible():
        page.locator("#toggle-panel").click()
    stage = page.locator("#stage").bounding_box()
    cw, ch = stage["width"] * dpr, stage["height"] * dpr
    scale = min(1.0, (1280 * 720 / (cw * ch)) ** 0.5, 1920 / cw, 1080 / ch)
    want = (round(cw * scale / 2) * 2, round(ch * scale / 2) * 2)
    page.wait_for_function(f"document.getElementById('view').width === {want[0]}"
                           f" && document.getElementById('view').height === {want[1]}", timeout=30000)
    assert want[0] * want[1] <= 1280 * 720 + 2 * (want[0] + want[1])
    if w < 1000:
        assert want == (round(cw / 2) * 2, round(ch / 2) * 2)       # a small view: every device pixel
    ctx.close()


def test_views_that_teach_replace_the_frame_and_show_their_scale(server, browser):
    """The view switch: transmittance (grey frames), one layer's optical depth (the layer
    menu lists the look's layers), and analytic - raymarch with its max |dT| in the legend,
    as the server's view_stats said; back to the look."""
    stats = []

    def listen(page):
        page.on("websocket", lambda ws: ws.on("framereceived", lambda m: stats.append(json.loads(m))
                                              if isinstance(m, str) and '"view_stats"' in m else None))

    page = new_page(browser, server.url + "/?v=1&play=0", before=listen)
    wait_frames(page, 1)
    page.select_option("#show", "transmittance")
    page.wait_for_function("window.fogbank.store.get().viewStats?.show === 'transmittance'"
                           " && window.fogbank.store.get().lastFrame?.frame >= window.fogbank.store.get().viewStats.frame")
    time.sleep(0.5)
    px = canvas_pixels(page)
    assert np.abs(px[..., 0] - px[..., 2]).mean() < 2          # grey: T, not the shaded look
    assert page.locator("#legend-label").inner_text() == "transmittance T"
    page.select_option("#show", "optical_depth")
    assert page.locator("#show-layer").is_visible()
    layers = page.evaluate("window.fogbank.store.get().params.layers.map((l) => l.kind)")
    assert page.eval_on_selector_all("#show-layer option", "os => os.map(o => o.textContent)") == \
        [f"{i + 1}. {k}" for i, k in enumerate(layers)]
    page.select_option("#show-layer", "1")
    page.wait_for_function("window.fogbank.store.get().viewStats?.show === 'optical_depth'"
                           " && window.fogbank.store.get().viewStats.layer === 1")
    assert f"layer 2 ({layers[1]})" in page.locator("#legend-stats").inner_text()
    page.select_option("#show", "difference")
    page.wait_for_function("window.fogbank.store.get().viewStats?.show === 'difference'")
    last = [m for m in stats if m["show"] == "difference"][-1]
    text = page.locator("#legend-stats").inner_text()
    assert f"max |ΔT| {last['max_abs_dT']:.2e}".replace("e-0", "e-") in text or \
        f"max |ΔT| {last['max_abs_dT']:.3g}" in text
    assert last["max_abs_dT"] < 1e-3        # the default look's closed forms against 256 steps
    page.select_option("#show", "shaded")
    page.wait_for_function("document.getElementById('legend').hidden")
    assert page.errors == []
    page.context.close()


def test_a_costly_look_blurs_its_preview_while_dragged_not_the_frame_rate(server, browser):
    """Finding 4: with 7-9 layers the stream fell to 2-9 fps. While the view is dragged,
    previews that cost more than the budget are drawn smaller (scaled up on the canvas,
    "refining…" shown); when the drag ends, the full frame is the stream's own size."""
    layers = [("height", ""), ("cosine", ""), ("potential", ""), ("sphere", ""), ("box", ""),
              ("ellipsoid", ""), ("homogeneous", "&layers.6.density=0.002"), ("polynomial", "")]
    q = f"v=1&play=0&layers={len(layers)}" + "".join(f"&layers.{i}.kind={k}{x}" for i, (k, x) in enumerate(layers))
    page = new_page(browser, f"{server.url}/?{q}")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    full = page.evaluate("[window.fogbank.store.get().lastFrame.width, window.fogbank.store.get().lastFrame.height]")
    page.evaluate("window.fogbank.store.subscribe((s, p) => {"
                  " if (s.lastFrame !== p.lastFrame) window.__frames?.push([s.lastFrame.width, s.lastFrame.full]); }); 0")
    box = page.locator("#view").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2

    def drag():
        page.evaluate("window.__frames = []")
        page.mouse.move(x, y)
        page.mouse.down()
        refining = False
        for i in range(40):
            page.mouse.move(x + 3 * i, y)
            time.sleep(0.05)
            refining = refining or page.locator("#stat-refining").is_visible()
        page.mouse.up()
        wait_full_frame_of_current_version(page)
        frames = page.evaluate("window.__frames")
        return frames, [w for w, is_full in frames if not is_full], refining
    # a loaded machine (the whole suite on 2 cores) once gave 1 preview in the 2 s drag
    # where the test alone gives 12-20: a miss is measured again once, and a page whose
    # drag draws no previews misses both
    frames, previews, refining = drag()
    if not (len(previews) >= 5 and refining):
        print(f"\nfirst drag: {len(previews)} previews, refining shown {refining}; again")
        frames, previews, refining = drag()
    assert len(previews) >= 5 and refining
    assert min(previews) < full[0]                   # smaller while dragged
    assert frames[-1] == [full[0], True]              # the refinement: the stream's own size
    assert page.evaluate("[document.getElementById('view').width, document.getElementById('view').height]") == full
    assert page.errors == []
    page.context.close()
