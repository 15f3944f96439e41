"""Every setting of the service, in one place (environment variables FOGBANK_*)."""

from __future__ import annotations

from functools import lru_cache
from typing import Literal

from pydantic import Field, ValidationError
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="FOGBANK_", extra="ignore")

    host: str = Field("127.0.0.1", description="address the server binds")
    port: int = Field(8000, ge=1, le=65535, description="TCP port")
    gl_backend: Literal["auto", "egl", "default"] = Field(
        "auto", description="'auto' and 'egl' use EGL (the GPU where there is one, else llvmpipe); "
        "'default' lets glcontext pick (GLX/WGL/CGL)")
    gl_device: int | None = Field(None, ge=0, description="EGL device index; unset picks the first")
    render_timeout_s: float = Field(60.0, gt=0, description="how long a request waits for the renderer")
    encode_threads: int = Field(2, ge=1, le=32, description="threads that encode images")
    max_sessions: int = Field(32, ge=1, le=10000, description="streaming sessions per process; "
                              "the next is refused with close code 1013")
    max_stills: int = Field(4, ge=1, le=256, description="still renders at once; beyond, 503")
    messages_per_s: float = Field(120.0, gt=0, description="per-socket message rate (token bucket)")
    message_burst: int = Field(240, ge=1, description="per-socket burst of messages")
    allowed_origins: str = Field("", description="comma-separated Origins allowed on /ws besides "
                                 "the server's own host; '*' allows any")


class SettingsError(ValueError):
    """A setting's value is not allowed; the message names the key and the value."""


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    try:
        return Settings()
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            key = "FOGBANK_" + "_".join(str(p) for p in err["loc"]).upper()
            lines.append(f"{key}={err.get('input')!r}: {err['msg']}")
        raise SettingsError("bad setting: " + "; ".join(lines)) from None
