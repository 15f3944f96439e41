"""The page's screenshots in docs/screenshots: the README's (1280x800) and the page at
1024x768, 1920x1080 and phone landscape (844x390), each of the default look once its
full-quality frame is on screen. Starts its own server on 127.0.0.1 (stopped by PID).

    .venv/bin/python scripts/screenshots.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

SIZES = {"page": (1280, 800, False), "page-1024x768": (1024, 768, False),
         "page-1920x1080": (1920, 1080, False), "page-phone-landscape": (844, 390, True)}


def main() -> None:
    from PIL import Image
    from playwright.sync_api import sync_playwright
    from servers import Server
    out = ROOT / "docs" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    server = Server().start()
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium")
            for name, (w, h, phone) in SIZES.items():
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
