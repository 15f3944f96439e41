import os

import pytest

os.environ.setdefault("FOGBANK_GL_BACKEND", "egl")


@pytest.fixture(scope="session")
def renderer():
    from fogbank.render.renderer import Renderer, create_context
    return Renderer(create_context("egl"))


@pytest.fixture(scope="session")
def client():
    from fastapi.testclient import TestClient

    from fogbank.service.api import create_app
    with TestClient(create_app()) as c:
        yield c


CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="session")
def browser():
    """Debian's Chromium driven by Playwright (never `playwright install`)."""
    from pathlib import Path
    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} is missing: `make test` installs Debian's chromium (as root)")
    from playwright.sync_api import sync_playwright
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        yield b
        b.close()
