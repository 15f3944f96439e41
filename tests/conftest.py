import os

import pytest

os.environ.setdefault("FOGBANK_GL_BACKEND", "egl")


@pytest.fixture(scope="session")
def renderer():
    from fogbank.renderer import Renderer, create_context
    return Renderer(create_context("egl"))


@pytest.fixture(scope="session")
def client():
    from fastapi.testclient import TestClient

    from fogbank.api import create_app
    with TestClient(create_app()) as c:
        yield c
