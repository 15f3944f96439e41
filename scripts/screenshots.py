"""The page's screenshots in docs/screenshots: the README's (1280x800) and the page at
1024x768, 1920x1080 and phone landscape (844x390), each of the default look once its
full-quality frame is on screen; and docs/issue12/, one per finding of issue 12 fixed
(the panel's help and sections, a layer's formula, the views that teach, the ray plot,
the function editor, a link's framing, a bad link's notice, the over-long link's page).
Starts its own server on 127.0.0.1 (stopped by PID).

    .venv/bin/python scripts/screenshots.py [--only issue12]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

SIZES = {"page": (1280, 800, False), "page-1024x768": (1024, 768, False),
         "page-1920x1080": (1920, 1080, False), "page-phone-landscape": (844, 390, True)}


def _save(page, path: Path, **kw) -> None:
    from PIL import Image
    png = path.with_suffix(".png")
    page.screenshot(path=str(png), **kw)
    Image.open(png).convert("RGB").save(path.with_suffix(".jpg"), quality=85)
    png.unlink()
    print(path.with_suffix(".jpg"))


def _quiet(page) -> None:
    page.wait_for_function("(() => { const c = document.getElementById('view');"
                           " return c.dataset.full === 'true' && Number(c.dataset.frames) >= 1; })()", timeout=120000)
    time.sleep(1.0)


def _open(browser, link: str, w: int = 1280, h: int = 800):
    """(context, page) of `link` in a window of w x h, once its full frame is on screen."""
    ctx = browser.new_context(viewport={"width": w, "height": h}, bypass_csp=True)
    page = ctx.new_page()
    page.goto(link)
    _quiet(page)
    return ctx, page


def issue12(browser, url: str) -> None:
    """One screenshot per finding of issue 12, fixed."""
    out = ROOT / "docs" / "issue12"
    out.mkdir(parents=True, exist_ok=True)
    # 1, 2, 3: the panel in sections, a layer's sentence, formula and source, a field's help
    ctx, page = _open(browser, url + "/?v=1&time=40&play=0")
    page.locator("[data-path='layers.0.density']").locator("xpath=..").locator("label").hover()
    _save(page, out / "2-help-formula-and-field")
    # 3: undo and the resets above the panel after an edit; the camera section's bounds
    page.locator("[data-path='density']").fill("1.6")
    page.locator("[data-path='density']").press("Enter")
    time.sleep(1.0)
    page.locator("[data-section=Camera] > summary").click()
    page.locator("[data-section=Camera]").scroll_into_view_if_needed()
    page.locator("[data-path='camera.position.0']").hover()
    _save(page, out / "3-camera-bounds-and-sections")
    # the views that teach
    page.goto(url + "/?v=1&time=40&play=0")
    _quiet(page)
    for show, name in (("transmittance", "views-transmittance"), ("optical_depth", "views-optical-depth"),
                       ("difference", "views-analytic-vs-raymarch")):
        page.select_option("#show", show)
        if show == "optical_depth":
            page.select_option("#show-layer", "1")
        page.wait_for_function(f"window.fogbank.store.get().viewStats?.show === '{show}'", timeout=120000)
        time.sleep(1.5)
        _save(page, out / name)
    page.select_option("#show", "shaded")
    # the ray plot
    page.check("#probe")
    box = page.locator("#view").bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.45, box["y"] + box["height"] * 0.6)
    page.wait_for_selector("#plot .info:not(:empty)")
    time.sleep(1.0)
    _save(page, out / "views-ray-plot")
    page.uncheck("#probe")
    # the function editor, a shape that breaks the rule shown where it breaks
    page.goto(url + "/?v=1&preset=biri-fig7&play=0")
    _quiet(page)
    page.locator("details.shape > summary").first.click()
    page.wait_for_selector(".function-editor circle.point")
    mid = page.locator(".function-editor circle.point[data-index='2']")
    mid.scroll_into_view_if_needed()
    b = mid.bounding_box()
    page.mouse.move(b["x"] + b["width"] / 2, b["y"] + b["height"] / 2)
    page.mouse.down()
    page.mouse.move(b["x"] + b["width"] / 2, b["y"] + 70, steps=6)
    page.mouse.up()
    page.wait_for_selector(".function-editor circle.broken")
    time.sleep(0.5)
    _save(page, out / "views-function-editor-refuses-a-negative-shape")
    ctx.close()
    # 4: "Add layer" adds a layer that suits the look, opened, and never a white-out
    ctx, page = _open(browser, url + "/?v=1&time=40&play=0")
    add = page.locator("fieldset.list .add").filter(has=page.get_by_role("button", name="Add layer"))
    add.locator("select").select_option("sphere")
    add.get_by_role("button", name="Add layer").click()
    page.wait_for_function("window.fogbank.store.get().confirmed.params.layers.length === 5")
    _quiet(page)
    page.locator("[data-section=Layers] > fieldset.list > details.item").nth(4).scroll_into_view_if_needed()
    _save(page, out / "4-added-layer-opens-and-suits-the-look")
    # 4: a costly look while dragged: a smaller preview, "refining…", not a stalled page
    layers = ["height", "cosine", "potential", "sphere", "box", "ellipsoid", "polynomial", "homogeneous"]
    q = f"v=1&play=0&layers={len(layers)}" + "".join(f"&layers.{i}.kind={k}" for i, k in enumerate(layers))
    page.goto(url + "/?" + q + "&layers.7.density=0.002")
    _quiet(page)
    box = page.locator("#view").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for i in range(30):
        page.mouse.move(x + 4 * i, y + i)
        time.sleep(0.05)
    _save(page, out / "4-costly-look-previewed-smaller-while-dragged")
    page.mouse.up()
    ctx.close()
    # 5: a link with a bad part keeps the rest, and says what was left out
    ctx, page = _open(browser, url + "/?v=1&preset=biri-fig7&density=2&wind.speed=banana&play=0")
    _save(page, out / "5-bad-link-keeps-the-rest")
    # 5: an over-long link's page
    page.goto(url + "/?v=1&density=2&pad=" + "a" * 100_000)
    _save(page, out / "5-over-long-link-page")
    ctx.close()
    # 7: a 16:9 link opened in a tall window keeps its framing
    ctx, page = _open(browser, url + "/?v=1&time=40&play=0&aspect=1.778", 900, 1000)
    if page.locator("#panel").is_visible():
        page.locator("#toggle-panel").click()
        time.sleep(1.0)
    _save(page, out / "7-link-framing-kept")
    ctx.close()


def main() -> None:
    from PIL import Image
    from playwright.sync_api import sync_playwright
    from servers import Server
    out = ROOT / "docs" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    server = Server().start()
    only = sys.argv[2] if sys.argv[1:2] == ["--only"] else None
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium")
            if only in (None, "issue12"):
                issue12(browser, server.url)
            for name, (w, h, phone) in ({} if only == "issue12" else SIZES).items():
                ctx = browser.new_context(viewport={"width": w, "height": h}, bypass_csp=True,
                                          **({"is_mobile": True, "has_touch": True} if phone else {}))
                page = ctx.new_page()
                page.goto(server.url + "/?v=1&time=40&play=0")
                page.wait_for_function("(() => { const c = document.getElementById('view');"
                                       " return c.dataset.full === 'true' && Number(c.dataset.frames) >= 1; })()",
                                       timeout=120000)
                time.sleep(1.0)
                png = out / f"{name}.png"
                page.screenshot(path=str(png))
                Image.open(png).convert("RGB").save(out / f"{name}.jpg", quality=85)
                png.unlink()
                ctx.close()
                print(out / f"{name}.jpg")
            browser.close()
    finally:
        server.stop()


if __name__ == "__main__":
    main()
