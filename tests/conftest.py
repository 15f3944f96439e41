import os
from pathlib import Path

import pytest

os.environ.setdefault("FOGBANK_GL_BACKEND", "egl")
# Starlette's TestClient sends Host "testserver" (its WebSockets always): the in-process
# apps answer it besides the default names (service/security.py HostCheck)
os.environ.setdefault("FOGBANK_ALLOWED_HOSTS", "localhost,127.0.0.1,::1,testserver")

# Tests mirror the package by tier: tests/<tier>/test_<module>.py. The folder is the
# marker, so `pytest -m unit` runs the fast tier (no GL context, no server, no browser).
TIERS = ("unit", "gl", "service", "browser")


def pytest_collection_modifyitems(config, items):
    for item in items:
        tier = Path(str(item.fspath)).parent.name
        if tier not in TIERS:
            raise pytest.UsageError(f"{item.nodeid}: a test lives in tests/<tier>/, tier one of {TIERS}")
        item.add_marker(getattr(pytest.mark, tier))
    # fast tiers first; the browser tier last, since Playwright's sync API keeps an event
    # loop running on the main thread for the rest of the session (asyncio.run fails after)
    items.sort(key=lambda item: TIERS.index(Path(str(item.fspath)).parent.name))


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
