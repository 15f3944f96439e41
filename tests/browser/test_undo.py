"""Undo and redo of look changes (static/undo.js, wired in app.js), resets to the preset
and its camera, and the scene's camera bounds, in Chromium against a real server (issue
12, finding 3). The expected looks are the server's own confirmed states before each
change and the presets and bounds from the API, never the page's memory of them."""

from __future__ import annotations

import json
import urllib.request


from pages import drag_view, new_page, panel_and_state, wait_frames, wait_quiet


def _get(server, path):
    with urllib.request.urlopen(server.url + path) as r:
        return json.loads(r.read())


def _look(page):
    """The server's confirmed look, without the animation's time."""
    p = page.evaluate("window.fogbank.store.get().confirmed.params")
    p.pop("time")
    return p


def _type(page, path, value):
    page.locator(f"[data-path='{path}']").fill(str(value))
    page.locator(f"[data-path='{path}']").press("Enter")
    page.wait_for_function(
        "([path, want]) => { let v = window.fogbank.store.get().confirmed.params;"
        " for (const k of path.split('.')) v = v[k]; return v === want; }", arg=[path, value])


def _settle(page, look):
    page.wait_for_function("(want) => { const p = {...window.fogbank.store.get().confirmed.params};"
                           " delete p.time; return JSON.stringify(p) === JSON.stringify(want); }", arg=look)


def test_ctrl_z_undoes_edits_and_a_preset_and_ctrl_shift_z_redoes_them(server, browser):
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    looks = [_look(page)]
    assert page.locator("#undo").is_disabled()
    _type(page, "density", 2.5)
    looks.append(_look(page))
    _type(page, "wind.speed", 7)
    looks.append(_look(page))
    page.select_option("#preset", "quilez-spheres")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.layers.length === 3")
    page.locator("#play").click()     # a preset plays: paused, so that the view goes quiet
    page.wait_for_function("window.fogbank.store.get().confirmed.playing === false")
    wait_quiet(page)
    looks.append(_look(page))
    # a camera drag is not a look change: undo keeps it (for edits) ...
    page.locator("#view").focus()
    for want in (looks[2], looks[1]):
        page.keyboard.press("Control+z")
        if want is looks[2]:    # undoing the preset brings its camera back too
            _settle(page, want)
            drag_view(page, -10, 0)
            wait_quiet(page)
            camera = page.evaluate("window.fogbank.store.get().confirmed.params.camera")
            assert camera != want["camera"]
            continue
        _settle(page, {**want, "camera": camera})
    shown, expected = panel_and_state(page)
    assert shown == expected
    # ... redo twice: the wind, then the preset with its camera
    page.keyboard.press("Control+Shift+z")
    _settle(page, {**looks[2], "camera": camera})
    page.locator("#redo").click()
    _settle(page, looks[3])
    assert page.locator("#redo").is_disabled()
    shown, expected = panel_and_state(page)
    assert shown == expected
    assert page.errors == []
    page.context.close()


def test_reset_camera_and_reset_to_preset_go_back_to_the_preset(server, browser):
    presets = {p["name"]: p for p in _get(server, "/api/presets")}
    page = new_page(browser, server.url + "/?v=1&preset=biri-fig7&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    _type(page, "density", 3)
    drag_view(page, 15, 4)
    wait_quiet(page)
    page.locator("#reset-camera").click()
    page.wait_for_function("(want) => JSON.stringify(window.fogbank.store.get().confirmed.params.camera)"
                           " === JSON.stringify(want)", arg=presets["biri-fig7"]["params"]["camera"])
    assert page.evaluate("window.fogbank.store.get().confirmed.params.density") == 3
    assert page.locator("#about-title").inner_text() == f"Custom look, from “{presets['biri-fig7']['title']}”"
    page.locator("#reset-look").click()
    want = dict(presets["biri-fig7"]["params"])
    want.pop("time")
    _settle(page, want)
    assert page.locator("#preset").input_value() == "biri-fig7"
    assert page.errors == []
    page.context.close()


def test_the_camera_stays_within_the_scene(server, browser):
    """Finding 3: x = 1e12 was taken and the scene vanished. Typed positions, flights and
    the wheel are held to the scene's bounds from the schema."""
    bounds = _get(server, "/api/schema")["camera_bounds"]["countryside"]
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    page.locator("[data-section=Camera] > summary").click()
    page.locator("[data-path='camera.position.0']").fill("1000000000000")
    page.locator("[data-path='camera.position.0']").press("Enter")
    page.wait_for_function(f"window.fogbank.store.get().confirmed.params.camera.position[0] === {bounds['max'][0]}")
    assert "stays within the countryside scene" in page.locator("#toast").inner_text()
    # looking along +x from the edge, the wheel moves the eye no further out
    page.locator("[data-path='camera.yaw']").fill("90")
    page.locator("[data-path='camera.yaw']").press("Enter")
    page.locator("[data-path='camera.pitch']").fill("0")
    page.locator("[data-path='camera.pitch']").press("Enter")
    page.wait_for_function("window.fogbank.store.get().confirmed.params.camera.pitch === 0")
    box = page.locator("#view").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    for _ in range(10):
        page.mouse.wheel(0, -400)
    wait_quiet(page)
    pos = page.evaluate("window.fogbank.store.get().confirmed.params.camera.position")
    assert all(lo <= v <= hi for v, lo, hi in zip(pos, bounds["min"], bounds["max"]))
    assert pos[0] == bounds["max"][0]
    assert page.errors == []
    page.context.close()
