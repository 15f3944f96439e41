"""The panel's controls (static/controls.js) in Chromium against a real server: help in
place, the artist's sections, log sliders, fine drag and double-click reset (issue 12,
findings 2 and 3). References are computed here from the JSON Schema and the kinds'
modules, not read back from the page."""

from __future__ import annotations

import json
import math
import urllib.request

import pytest

from fogbank.kinds import KINDS
from fogbank.model import presets as P
from pages import new_page, wait_frames, wait_quiet


@pytest.fixture(scope="module")
def schema(server):
    with urllib.request.urlopen(server.url + "/api/schema") as r:
        return json.loads(r.read())


def _resolve(schema, node):
    while "$ref" in node:
        node = schema["$defs"][node["$ref"].split("/")[-1]]
    return node


def _groups(schema, value, node=None, path=(), group=None, out=None):
    """{data-path: section} for every control of `value`, walked here from the schema:
    an object's fields take its group unless they name their own."""
    out = {} if out is None else out
    node = node or schema
    for name, prop in _resolve(schema, node)["properties"].items():
        if not path and name in ("time", "width", "height"):
            continue
        sub = _resolve(schema, prop)
        g = prop.get("group") or sub.get("group") or group
        p = (*path, name)
        if sub.get("type") == "object" or ("properties" in sub and "prefixItems" not in sub):
            _groups(schema, value[name], prop, p, g, out)
        elif name == "layers":
            out["layers"] = g      # the list: its items' fields sit in the same section
            for i, layer in enumerate(value[name]):
                for f in KINDS[layer["kind"]].model.model_fields:
                    out[f"layers.{i}.{f}"] = g
        else:
            out[".".join(p)] = g
    return out


def _slider(page, path):
    s = page.locator(f"[data-path='{path}']").locator("xpath=..").locator("input[type=range]")
    s.scroll_into_view_if_needed()
    return s


def _confirmed(page, path):
    v = page.evaluate("window.fogbank.store.get().confirmed.params")
    for k in path.split("."):
        v = v[int(k)] if isinstance(v, list) else v[k]
    return v


def _wait_confirmed(page, path, expected):
    page.wait_for_function(
        "([path, want]) => { let v = window.fogbank.store.get().confirmed.params;"
        " for (const k of path.split('.')) v = v[k]; return JSON.stringify(v) === JSON.stringify(want); }",
        arg=[path, expected])


def test_every_field_sits_once_in_the_section_its_schema_names(server, browser, schema):
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    params = page.evaluate("window.fogbank.store.get().params")
    expected = _groups(schema, params)
    got = page.evaluate("""[...document.querySelectorAll('#controls [data-path]')].map((e) =>
        [e.dataset.path, e.closest('details.section').dataset.section])""")
    want = {p: g for p, g in expected.items() if p != "layers" and not p.endswith((".kind", ".enabled"))}
    # a vector is one control per axis, a list of terms one per term's field: fold them
    # back onto the field that holds them
    placed = {}
    for path, section in got:
        parts = path.split(".")
        head = next((".".join(parts[:n]) for n in range(len(parts), 0, -1) if ".".join(parts[:n]) in want), path)
        placed.setdefault(head, set()).add(section)
    assert {p: s.pop() for p, s in placed.items() if len(s) == 1} == want
    assert all(len(s) <= 1 for s in placed.values())
    sections = page.evaluate("[...document.querySelectorAll('#controls > details.section')].map(e => e.dataset.section)")
    assert sections == [g for g in schema["groups"] if g in set(expected.values())]
    assert page.errors == []
    page.context.close()


def test_each_kind_and_preset_shows_its_source_sentence_and_formula(server, browser, schema):
    """One layer of every kind: its name, summary, source and a drawn MathML formula;
    the preset's title, description and source above the panel."""
    names = list(KINDS)
    q = "&".join([f"layers={len(names)}"] + [f"layers.{i}.kind={k}" for i, k in enumerate(names)]
                 + [f"layers.{i}.enabled=false" for i in range(len(names))])
    page = new_page(browser, server.url + f"/?v=1&play=0&{q}", h=900)
    wait_frames(page, 1)
    items = page.locator("[data-section=Layers] > fieldset.list > details.item")
    assert items.count() == len(names)
    for i, name in enumerate(names):
        model = KINDS[name].model
        item = items.nth(i)
        assert item.locator(":scope > summary .name").inner_text() == f"{i + 1}. {model.model_config['title']}"
        item.evaluate("e => { e.open = true; }")
        help_box = item.locator(":scope > .kind-help")
        assert help_box.locator(".summary").inner_text() == model.summary
        assert help_box.locator(".source").inner_text() == f"Source: {model.source}"
        math_box = help_box.locator("math").bounding_box()
        assert math_box is not None and math_box["width"] > 60 and math_box["height"] > 10
        # the formula's own symbols are drawn (MathML <mi>), not shown as LaTeX source
        assert "\\" not in help_box.locator(".formula").inner_text()
        item.evaluate("e => { e.open = false; }")
    # the preset above the panel: the default, then another one
    p = P.presets()
    assert page.locator("#about-title").inner_text().startswith("Custom look")
    page.select_option("#preset", "biri-fig7")
    page.wait_for_function("document.getElementById('about-title').textContent === " + json.dumps(p["biri-fig7"]["title"]))
    assert page.locator("#about-text").inner_text() == p["biri-fig7"]["description"]
    assert page.locator("#about-source").inner_text() == f"Source: {p['biri-fig7']['source']}"
    assert page.errors == []
    page.context.close()


def test_a_field_shows_its_meaning_unit_and_range_in_place(server, browser, schema):
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    node = schema["$defs"]["Wind"]["properties"]["speed"]
    field = page.locator("[data-path='wind.speed']").locator("xpath=..")
    assert not field.locator(".help").is_visible()
    field.locator("label").hover()
    text = field.locator(".help").inner_text()
    assert field.locator(".help").is_visible()
    assert node["description"] in text and f"unit: {node['unit']}" in text
    assert f"from {node['minimum']:g} to {node['maximum']:g}" in text
    # a layer's field: the kind's own words (no bare paper symbol as the label)
    first = page.locator("[data-section=Layers] > fieldset.list > details.item").first
    label = first.locator("[data-path='layers.0.density']").locator("xpath=..").locator("label").inner_text()
    assert label == "Density ρ₀"
    assert page.errors == []
    page.context.close()


def _log_value(node, f):
    """The log slider's value at a fraction f of its travel, from the schema's bounds and
    step: lo + step ((hi - lo) / step + 1)^f - step, to three significant figures."""
    lo, hi, step = node.get("minimum", node.get("exclusiveMinimum")), node["maximum"], node["step"]
    v = lo + step * math.expm1(f * math.log((hi - lo) / step + 1))
    return float(f"{v:.3g}")


def test_wide_ranges_have_log_sliders_that_take_small_steps(server, browser, schema):
    """Finding 3: 2% of a linear slider took a density from 0.035 to 0.199. The schema
    states which sliders are log; clicking at a fraction of the track sets the value the
    log mapping gives there, and 2% of travel moves a density by a ratio, not a leap."""
    node = schema["$defs"]["Height"]["properties"]["density"]
    assert node["scale"] == "log"
    assert schema["$defs"]["Wind"]["properties"]["direction"]["scale"] == "linear"
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    slider = _slider(page, "layers.0.density")
    assert slider.get_attribute("data-scale") == "log"
    box = slider.bounding_box()
    y = box["y"] + box["height"] / 2
    for f in (0.2, 0.5, 0.8):
        page.mouse.click(box["x"] + f * box["width"], y)
        want = _log_value(node, f)
        _wait_confirmed(page, "layers.0.density", want)
        assert float(page.locator("[data-path='layers.0.density']").input_value()) == want
    # 2% of travel from the middle: the density changes by (span / step + 1)^0.02, about 22%
    page.mouse.move(box["x"] + 0.5 * box["width"], y)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.52 * box["width"], y, steps=4)
    page.mouse.up()
    _wait_confirmed(page, "layers.0.density", _log_value(node, 0.52))
    ratio = _log_value(node, 0.52) / _log_value(node, 0.5)
    assert 1.1 < ratio < 1.35
    assert page.errors == []
    page.context.close()


def test_shift_drags_a_slider_ten_times_finer_and_a_double_click_resets_it(server, browser, schema):
    page = new_page(browser, server.url + "/?v=1&play=0")
    wait_frames(page, 1)
    wait_quiet(page)
    slider = _slider(page, "wind.direction")
    box = slider.bounding_box()
    x0, y = box["x"] + 0.25 * box["width"], box["y"] + box["height"] / 2
    page.mouse.click(x0, y)
    _wait_confirmed(page, "wind.direction", 90)
    span, px = 360.0, 40

    def drag(shift):
        start = _confirmed(page, "wind.direction")
        if shift:
            page.keyboard.down("Shift")
        page.mouse.move(x0, y)
        page.mouse.down()
        page.mouse.move(x0 + px, y, steps=10)
        page.mouse.up()
        if shift:
            page.keyboard.up("Shift")
        wait_quiet(page)
        return _confirmed(page, "wind.direction") - start

    coarse = drag(False)
    page.mouse.click(x0, y)
    _wait_confirmed(page, "wind.direction", 90)
    fine = drag(True)
    assert abs(coarse - span * px / box["width"]) <= 1
    assert abs(fine - 0.1 * span * px / box["width"]) <= 1
    # double-click the label: the schema's default
    page.locator("[data-path='wind.direction']").locator("xpath=..").locator("label").dblclick()
    _wait_confirmed(page, "wind.direction", schema["$defs"]["Wind"]["properties"]["direction"]["default"])
    assert page.errors == []
    page.context.close()


CONFIRMED_LAYER = "window.fogbank.store.get().confirmed?.params?.layers?.[{i}]"


def _commit(page, path: str, value) -> None:
    box = page.locator(f"[data-path='{path}']")
    box.fill(str(value))
    box.press("Enter")


def test_controls_keep_the_cross_field_rules_instead_of_offering_what_is_refused(server, browser):
    """Issue 37, item 1: on the default look the cosine amplitudes already sum to c0, so
    raising one was refused, with a validator's string over the view. Now (the kind's
    x-rules, kept by static/controls.js keepRules): raising an amplitude carries c0 up to
    the new sum, said next to the control; lowering c0 under the sum stops at it, said so;
    a particle layer's shortest life raised past its longest carries the longest along, and
    the longest lowered under the shortest stops there. The server confirms each look (no
    error message, nothing refused)."""
    page = new_page(browser, server.url + "/?v=1&time=3")
    wait_frames(page, 2)
    page.evaluate("""() => window.fogbank.stream.addEventListener("error",
        (e) => (window.__errors = (window.__errors || []).concat([e.detail.msg])))""")
    page.locator("details[data-section='Layers']").evaluate("d => d.open = true")
    page.locator("[data-path='layers.1.c0']").wait_for(state="attached")
    page.evaluate("""() => { for (const d of document.querySelectorAll('#controls details')) d.open = true; }""")
    # an amplitude raised: c0 follows it
    _commit(page, "layers.1.terms.0.amp", 2.5)   # the others sum to 0.5: c0 2.5 + 0.5 = 3.0
    page.wait_for_function(CONFIRMED_LAYER.format(i=1) + "?.c0 === 3")
    assert page.locator("[data-path='layers.1.c0']").input_value() == "3"
    note = page.locator(".rule-note")
    assert "raised to 3" in note.inner_text() and "never goes negative" in note.inner_text()
    from pathlib import Path
    shots = Path(__file__).resolve().parents[2] / "out" / "screenshots"
    shots.mkdir(parents=True, exist_ok=True)
    note.scroll_into_view_if_needed()
    page.screenshot(path=str(shots / "rule-note.png"))
    # c0 lowered under the sum: it stops there
    _commit(page, "layers.1.c0", 0.2)
    page.wait_for_selector(".rule-note:has-text('stops at 3')")
    assert page.locator("[data-path='layers.1.c0']").input_value() == "3"
    assert page.evaluate(CONFIRMED_LAYER.format(i=1) + ".c0") == 3
    # particles: the shortest life past the longest carries it; the longest under the shortest stops
    _commit(page, "layers.3.life_min", 60)
    page.wait_for_function(CONFIRMED_LAYER.format(i=3) + "?.life_max === 60")
    assert "raised to 60" in page.locator(".rule-note").inner_text()
    _commit(page, "layers.3.life_max", 10)
    page.wait_for_selector(".rule-note:has-text('stops at 60')")
    assert page.evaluate(CONFIRMED_LAYER.format(i=3) + ".life_max") == 60
    wait_frames(page, int(page.evaluate("document.getElementById('view').dataset.frames")) + 1)
    assert page.evaluate("window.__errors || []") == []
    assert page.errors == []
    page.context.close()
