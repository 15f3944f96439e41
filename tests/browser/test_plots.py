"""The page's plots (static/plot.js) in Chromium against a real server: the plot panel of
the ray under the cursor (rayplot.js) and the function editor (editor.js, Biri's Fig. 2).
References: the ground hit of the hovered pixel's ray from the hand-written camera, and
the polynomial through the editor's points evaluated here."""

from __future__ import annotations

import re

import numpy as np
import pytest

from hand import hand_rays
from fogbank.model.params import Camera
from pages import new_page, wait_frames, wait_quiet


def test_the_plot_panel_follows_the_ray_under_the_cursor(server, browser):
    cam = {"position": (0.0, 6.0, 0.0), "yaw": 0.0, "pitch": -6.0, "fov": 60.0}
    q = ("v=1&play=0&scene=calibration&camera.position=0,6,0&camera.yaw=0&camera.pitch=-6&camera.fov=60"
         "&layers=1&layers.0.kind=homogeneous&layers.0.density=0.01")
    page = new_page(browser, f"{server.url}/?{q}")
    wait_frames(page, 1)
    wait_quiet(page)
    page.check("#probe")
    box = page.locator("#view").bounding_box()
    cw, ch = page.evaluate("[document.getElementById('view').width, document.getElementById('view').height]")
    # the pointer at 70% across and 70% down the letterboxed frame (clear of the plot panel
    # on the left and the view switch on the right)
    scale = min(box["width"] / cw, box["height"] / ch)
    fx, fy = 0.7 * cw, 0.7 * ch
    page.mouse.move(box["x"] + (box["width"] - cw * scale) / 2 + fx * scale,
                    box["y"] + (box["height"] - ch * scale) / 2 + fy * scale)
    page.wait_for_function("document.querySelector('#plot .info').textContent.startsWith('ground')")
    x, y = float(page.locator("#plot").get_attribute("data-x")), float(page.locator("#plot").get_attribute("data-y"))
    assert abs(x - fx) <= 1 and abs(y - fy) <= 1
    w = hand_rays(Camera(**cam), [x], [ch - 1 - y], cw, ch)[0]
    d = -6.0 / w[1]
    shown = float(re.search(r"at ([0-9.]+) m", page.locator("#plot .info").inner_text()).group(1))
    assert abs(shown - d) <= 1.0
    t = float(re.search(r"T = ([0-9.e-]+)", page.locator("#plot .info").inner_text()).group(1))
    assert t == pytest.approx(np.exp(-0.01 * shown), rel=2e-3)
    assert page.locator("#plot path[data-name='1. homogeneous']").count() == 1
    assert page.errors == []
    page.context.close()


def _points(page):
    return [float(re.search(r": (\S+)$", a).group(1))
            for a in page.eval_on_selector_all(".function-editor circle.point", "cs => cs.map(c => c.getAttribute('aria-label'))")]


def test_the_function_editor_shapes_a_polynomial_and_refuses_a_negative_one(server, browser):
    page = new_page(browser, f"{server.url}/?v=1&preset=biri-fig7&play=0", h=900)
    wait_frames(page, 1)
    wait_quiet(page)
    item = page.locator("[data-section=Layers] > fieldset.list > details.item").first
    item.locator("details.shape > summary").click()
    page.wait_for_selector(".function-editor circle.point")
    before = page.evaluate("window.fogbank.store.get().confirmed.params.layers[0].coeffs")
    assert _points(page) == pytest.approx([2.8, 1.36, 0.8, 0.363, 0.8], abs=0.01)
    mid = page.locator(".function-editor circle.point[data-index='2']")
    mid.scroll_into_view_if_needed()
    b = mid.bounding_box()
    cx, cy = b["x"] + b["width"] / 2, b["y"] + b["height"] / 2

    def drag(dy):
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx, cy + dy, steps=6)
        page.mouse.up()

    # up a little: a valid shape goes to the look, its polynomial through the points shown
    drag(-15)
    page.wait_for_function("(b) => JSON.stringify(window.fogbank.store.get().confirmed.params.layers[0].coeffs)"
                           " !== JSON.stringify(b)", arg=before)
    assert page.locator(".function-editor .problems").inner_text() == ""
    coeffs = page.evaluate("window.fogbank.store.get().confirmed.params.layers[0].coeffs")
    knots = np.linspace(-1, 1, 5)
    values = [sum(c * k ** i for i, c in enumerate(coeffs)) for k in knots]
    assert values == pytest.approx(_points(page), rel=2e-3, abs=2e-3)
    assert values[2] > 0.9
    assert min(sum(c * u ** i for i, c in enumerate(coeffs)) for u in np.linspace(-1, 1, 401)) >= 0
    # down below zero: the rule and where it breaks, and the look keeps its coefficients
    b = mid.bounding_box()
    cx, cy = b["x"] + b["width"] / 2, b["y"] + b["height"] / 2
    drag(80)
    page.wait_for_selector(".function-editor circle.broken[data-rule='negative']")
    assert "< 0" in page.locator(".function-editor .problems").inner_text()
    assert _points(page)[2] < 0
    wait_quiet(page)
    assert page.evaluate("window.fogbank.store.get().confirmed.params.layers[0].coeffs") == coeffs
    assert page.errors == []
    page.context.close()
