"""The browser tier's server: one real uvicorn process on 127.0.0.1 for all the page
tests (started as its own process, stopped by its PID). Tests that restart or starve a
server start their own."""

from __future__ import annotations

import pytest

from servers import Server


@pytest.fixture(scope="session")
def server():
    s = Server().start()
    yield s
    s.stop()
