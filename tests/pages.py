"""What the browser tests share: a page on a real server, waits on its frames and state,
a drag on the view, the canvas's pixels, and the panel against the look it should show."""

from __future__ import annotations

import base64
import io
import re
import time

import numpy as np
from PIL import Image


def new_page(browser, url, w=1100, h=640, bypass_csp=True, before=None):
    # Playwright's wait_for_function evaluates strings, which the page's CSP forbids (no
    # 'unsafe-eval'); test_page_runs_under_its_csp checks the page with the CSP enforced
    ctx = browser.new_context(viewport={"width": w, "height": h}, bypass_csp=bypass_csp)
    ctx.grant_permissions(["clipboard-read", "clipboard-write"], origin=url.split("/?")[0].rstrip("/"))
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    if before:
        before(page)   # e.g. listeners that must see the page from its first message
    page.goto(url)
    page.errors = errors
    return page


def wait_frames(page, n=3, timeout=60000):
    page.wait_for_function(f"Number(document.getElementById('view').dataset.frames || 0) >= {n}",
                           timeout=timeout)


def shown_version(page) -> int:
    """The params version of the frame on the canvas."""
    return int(page.evaluate("document.getElementById('view').dataset.version"))


def wait_full_frame_of_current_version(page, timeout=60000, newer_than: int | None = None):
    """Until a full-quality frame (not reduced: the refinement climbs to it, also paused)
    shows the look the server last confirmed, and, with
    `newer_than` (shown_version before a change), one newer than that: right after an
    input the server may not have confirmed it yet, and the full frame shown then is the
    old look's, about to give way to a preview (the same size only by chance)."""
    newer = f" && Number(c.dataset.version) > {int(newer_than)}" if newer_than is not None else ""
    page.wait_for_function(
        "(() => { const c = document.getElementById('view');"
        " return c.dataset.full === 'true' && c.dataset.reduced !== 'true'"
        " && Number(c.dataset.version) >= window.fogbank.version"
        + newer + "; })()",
        timeout=timeout)
    time.sleep(0.3)   # let the canvas draw finish


def wait_quiet(page, quiet_s=1.0, timeout=60):
    """Until no frame has arrived for `quiet_s` and no patch waits to be sent."""
    deadline = time.monotonic() + timeout
    last, since = None, time.monotonic()
    while time.monotonic() < deadline:
        now = page.evaluate("(() => { const s = window.fogbank.store.get();"
                            " return [s.frames, !!(s.pendingParams || s.pendingCamera || s.flushQueued)]; })()")
        if now != last:
            last, since = now, time.monotonic()
        elif not now[1] and time.monotonic() - since >= quiet_s:
            return
        time.sleep(0.1)
    raise AssertionError("the stream did not go quiet")


def drag_view(page, dx, dy, steps=10):
    """Drag the view from its centre, `steps` moves of (dx, dy) pixels."""
    box = page.locator("#view").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for i in range(1, steps + 1):
        page.mouse.move(x + dx * i, y + dy * i)
        time.sleep(0.03)
    page.mouse.up()


def canvas_pixels(page) -> np.ndarray:
    url = page.evaluate("document.getElementById('view').toDataURL('image/png')")
    data = base64.b64decode(url.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).astype(int)


PANEL = """[...document.querySelectorAll('#controls [data-path]')].map((e) =>
  [e.dataset.path, e.type, e.type === 'checkbox' ? e.checked : e.value])"""


def _at(params, path):
    v = params
    for key in path.split("."):
        v = v[int(key)] if isinstance(v, list) else v[key]
    return v


def _shown(kind, v):
    """What a control of this input type shows for the value `v` (as the panel writes it)."""
    if kind == "checkbox":
        return bool(v)
    if v is None:
        return None
    if kind == "text" and isinstance(v, list):
        return [float(x) for x in v]
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    return str(v).lower()


def _read(kind, raw):
    if kind == "checkbox":
        return raw
    if raw == "":
        return None
    if kind == "text":
        return [float(x) for x in re.split(r"[,\s]+", raw) if x]
    try:
        return float(raw)
    except ValueError:
        return raw.lower()


def panel_and_state(page):
    """(what the panel shows, what it should show for the look on screen) by data-path."""
    params = page.evaluate("window.fogbank.store.get().params")
    panel = page.evaluate(PANEL)
    shown = {path: _read(kind, raw) for path, kind, raw in panel}
    expected = {path: _shown(kind, _at(params, path)) for path, kind, _ in panel}
    return shown, expected


