"""The page in a real browser: Playwright driving Debian's Chromium against a real
uvicorn server on 127.0.0.1 (started as its own process, stopped by its PID).

Screenshots go to out/screenshots/ (ignored by git)."""

from __future__ import annotations

import base64
import io
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from servers import Server

SHOTS = Path(__file__).resolve().parents[2] / "out" / "screenshots"


@pytest.fixture(scope="module")
def server():
    s = Server().start()
    yield s
    s.stop()


def new_page(browser, url, w=1280, h=720, bypass_csp=True):
    # Playwright's wait_for_function evaluates strings, which the page's CSP forbids (no
    # 'unsafe-eval'); test_page_runs_under_its_csp checks the page with the CSP enforced
    ctx = browser.new_context(viewport={"width": w, "height": h}, bypass_csp=bypass_csp)
    ctx.grant_permissions(["clipboard-read", "clipboard-write"], origin=url.split("/?")[0].rstrip("/"))
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.errors = errors
    return page


def wait_frames(page, n=3, timeout=60000):
    page.wait_for_function(f"Number(document.getElementById('view').dataset.frames || 0) >= {n}",
                           timeout=timeout)


def wait_full_frame_of_current_version(page, timeout=60000):
    """Until a full-quality frame shows the look the server last confirmed."""
    page.wait_for_function(
        "(() => { const c = document.getElementById('view');"
        " return c.dataset.full === 'true' && Number(c.dataset.version) >= window.fogbank.version; })()",
        timeout=timeout)
    time.sleep(0.3)   # let the canvas draw finish


def canvas_pixels(page) -> np.ndarray:
    url = page.evaluate("document.getElementById('view').toDataURL('image/png')")
    data = base64.b64decode(url.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).astype(int)


def test_page_loads_and_frames_arrive(server, browser):
    page = new_page(browser, server.url + "/")
    wait_frames(page, 5)
    assert page.locator("#stat-renderer").inner_text().startswith(("llvmpipe", "NVIDIA", "AMD", "Mesa")) \
        or page.locator("#stat-renderer").inner_text() != "–"
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
    page.context.close()


def test_density_control_changes_picture_and_url(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=4&play=0")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    before = canvas_pixels(page)
    page.locator("[data-path='density']").fill("3")
    page.locator("[data-path='density']").press("Enter")
    page.wait_for_function("location.search.includes('density=3')")
    wait_full_frame_of_current_version(page)
    after = canvas_pixels(page)
    assert np.abs(after - before).mean() > 4
    assert page.errors == []
    page.context.close()


def test_copied_url_gives_the_same_picture_as_the_still(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=6&play=0&camera.yaw=20&density=1.5")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    page.locator("#copy-link").click()
    link = page.evaluate("navigator.clipboard.readText()")
    assert link == page.url and "camera.yaw=20" in link and "play=0" in link
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
    assert diff.mean() < 2.5, diff.mean()
    assert np.percentile(diff, 99) < 24
    fresh.context.close()


def test_dragging_the_view_moves_the_camera(server, browser):
    page = new_page(browser, server.url + "/?v=1&time=3&play=0")
    wait_frames(page, 1)
    wait_full_frame_of_current_version(page)
    before = canvas_pixels(page)
    box = page.locator("#view").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for i in range(1, 11):
        page.mouse.move(x - 12 * i, y + 2 * i)
        time.sleep(0.03)
    page.mouse.up()
    page.wait_for_function("location.search.includes('camera.yaw=')")
    yaw = float(page.evaluate("new URLSearchParams(location.search).get('camera.yaw')"))
    assert yaw != 5.0
    wait_full_frame_of_current_version(page)
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
        page = new_page(browser, s.url + "/?v=1&camera.yaw=30")
        wait_frames(page, 3)
        s.stop()
        page.wait_for_selector("#banner:not([hidden])", timeout=20000)
        assert "reconnecting" in page.locator("#banner").inner_text().lower()
        before = int(page.evaluate("document.getElementById('view').dataset.frames"))
        s.start()
        page.wait_for_selector("#banner[hidden]", state="attached", timeout=30000)
        wait_frames(page, before + 3)
        assert "camera.yaw=30" in page.url   # the same look, from the URL
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
    assert page.evaluate("document.activeElement.tagName") in ("BUTTON", "SELECT", "INPUT")
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
