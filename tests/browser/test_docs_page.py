"""/docs in Debian's Chromium: Swagger UI from assets this server ships, rendered under
the page's own CSP, with no request leaving 127.0.0.1 (it loaded from a CDN before, which
the CSP blocked and an offline install cannot reach)."""

from __future__ import annotations

from pathlib import Path

from servers import Server

SHOTS = Path(__file__).resolve().parents[2] / "out" / "screenshots"


def test_docs_render_offline_under_the_csp(browser):
    srv = Server().start()
    try:
        ctx = browser.new_context(viewport={"width": 1280, "height": 900})   # CSP enforced
        page = ctx.new_page()
        console, outside = [], []
        page.on("console", lambda m: console.append(m.text))
        page.on("request", lambda r: None if r.url.startswith(srv.url) else outside.append(r.url))
        page.goto(srv.url + "/docs")
        page.wait_for_selector(".swagger-ui .info .title", timeout=20000)
        page.wait_for_selector(".opblock-summary-path[data-path=\"/api/still\"]", timeout=20000)
        assert "fogbank" in page.inner_text(".swagger-ui .info .title")
        SHOTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(SHOTS / "docs.png"))
        assert outside == []
        assert [m for m in console if "Content Security Policy" in m or "Refused" in m] == []
        ctx.close()
    finally:
        srv.stop()
