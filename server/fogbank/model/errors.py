"""The one shape of every error fogbank sends, over HTTP and the WebSocket alike:

    {"detail": [{"loc": ["body", "layers", 0, "density"], "msg": "...", "type": "..."}]}

`loc` names the field (or the request part), `msg` says what is allowed, `type` is a
stable code; a small offending `input` may ride along.
"""

from __future__ import annotations

import json
import math
from typing import Any, Iterable

from pydantic import ValidationError


def error(loc: Iterable, msg: str, type_: str, **extra: Any) -> dict:
    """One error item."""
    return {"loc": list(loc), "msg": msg, "type": type_, **extra}


def from_validation(exc: ValidationError, prefix: Iterable = ()) -> list[dict]:
    """pydantic's errors as items, each loc under `prefix` (the request part)."""
    prefix = list(prefix)
    return [error([*prefix, *e["loc"]], e["msg"], e["type"], input=e.get("input"))
            for e in exc.errors(include_url=False)]


def _safe(v):
    """Text that can be sent as UTF-8: user strings may hold lone surrogates ('\\ud800'
    from a JSON escape), which made the 422 itself fail with a 500."""
    if isinstance(v, str):
        return v.encode("utf-8", "backslashreplace").decode("utf-8")
    return v


def clean(e: dict) -> dict:
    """A JSON-safe error item: loc, msg, type, and the offending input when it is small."""
    out = {"loc": [_safe(x) for x in e.get("loc", ())], "msg": _safe(str(e.get("msg", ""))),
           "type": e.get("type", "")}
    v = e.get("input")
    if isinstance(v, bool) or (isinstance(v, int) and abs(v) < 10 ** 200):
        out["input"] = v
    elif isinstance(v, str) and len(v) <= 200:
        out["input"] = _safe(v)
    elif isinstance(v, float):
        out["input"] = v if math.isfinite(v) else str(v)
    return out


def body(errors: Iterable[dict]) -> dict:
    """The response body: {"detail": [items]}."""
    return {"detail": [clean(e) for e in errors]}


def body_bytes(errors: Iterable[dict]) -> bytes:
    return json.dumps(body(errors)).encode()


def summary(errors: list[dict]) -> str:
    """"field.path: message" of the first error, for a one-line message."""
    if not errors:
        return "bad input"
    e = errors[0]
    return f"{'.'.join(map(str, e['loc']))}: {e['msg']}"
