"""The URL codec, derived from the params model.

A look is a readable query string of dotted field paths, defaults left out:

    v=1&camera.yaw=12&wind.speed=3&layers=2&layers.0.kind=height&layers.0.density=0.05
    &layers.1.kind=sphere&layers.1.center=0,8,0

- Objects are walked field by field; a leaf equal to the base is left out.
- A list of objects (layers, cosine terms) equal to the base is left out; otherwise its
  length is written (`layers=2`) and each item is written against its own class's
  defaults (`kind` always written, it chooses the class).
- Vectors and coefficient lists are comma-separated; colours drop the '#'; numbers use
  the shortest text that reads back to the same float.
- The base is the "default" preset, or the preset named by `preset=`. `v` is the
  codec version (1).

encode(decode(q)) is the canonical form of q; decode(encode(p)) == p.

A long look also has a compact form, `z=<base64url, no padding, of the raw deflate of
the readable query>`, with only the page's keys (`play`, `speed`, `time`: how the
animation plays and where it is) beside it. Every reader of a query (decode,
decode_lenient, view_state) inflates `z` and reads the text exactly as a readable query:
decode(compact(q)) == decode(q). The page makes it itself (static/links.js).
"""

from __future__ import annotations

import base64
import re
import zlib
from typing import Annotated, Any, Literal, Union, get_args, get_origin
from urllib.parse import parse_qsl, quote, unquote_plus

from pydantic import BaseModel, ValidationError

from fogbank.model import presets as P
from fogbank.model.errors import error, summary
from fogbank.model.params import LAYER_CLASSES, FogParams, StillParams

VERSION = 1
# Page-only keys: how the page plays the look, not the look. A still ignores them.
VIEW_KEYS = ("play", "speed", "aspect")   # aspect: the framing the link was copied with
_SAFE = ",.-_~"
_HEX = re.compile(r"^#[0-9a-f]{6}$")
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(inf|nan|infinity)", re.I | re.A)
# The longest query decoded, an inflated `z` included. Every valid look has a link: the
# longest (16 cosine layers of 8 terms, numbers at their longest text) is 25-28k
# characters (test_urlstate).
MAX_QUERY = 32768
# The longest `z` value: the longest look's compact form is 11-13k characters.
MAX_COMPACT = 16384
# A query longer than this is given in the compact form where a link is made (the page's
# "Copy link" and its WebSocket URL, static/links.js; a still's X-Fogbank-Query header).
# Short looks stay readable (people read them); past 2000 characters nobody reads a link,
# and many tools that carry links (chat, mail, some proxies and old browsers: 2048-8192)
# start to cut or refuse them. Compacting shrinks a look's text to 20-65% (the more
# digits its numbers have, the less).
LONG_QUERY = 2000
# Keys that may stand beside `z`: the page-only keys, and `time` (part of the look, but it
# says where the animation is: a link keeps it readable, and can change it uncompressed).
BESIDE_Z = (*VIEW_KEYS, "time")
_BASE64URL = re.compile(r"[A-Za-z0-9_-]*")
MAX_LIST = 64


class URLError(ValueError):
    """A malformed query; `errors` are FastAPI-shaped {loc, msg, type} dicts."""

    def __init__(self, errors: list[dict[str, Any]]):
        super().__init__("; ".join(summary([e]) for e in errors))
        self.errors = errors


# ---------------------------------------------------------------- types from the model


def _unwrap(ann: Any) -> Any:
    while get_origin(ann) is Annotated:
        ann = get_args(ann)[0]
    return ann


def _item_class(ann: Any, item: Any) -> type[BaseModel] | None:
    """The model class of a list item (discriminated unions pick it by `kind`)."""
    ann = _unwrap(ann)
    if get_origin(ann) is Union:
        kind = item.get("kind") if isinstance(item, dict) else None
        return LAYER_CLASSES.get(kind)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    return None


def _first_class(ann: Any) -> type[BaseModel] | None:
    ann = _unwrap(ann)
    if get_origin(ann) is Union:
        return _unwrap(get_args(ann)[0])
    return None


def _list_arg(ann: Any) -> Any | None:
    ann = _unwrap(ann)
    if get_origin(ann) is list:
        return get_args(ann)[0]
    return None


def _format(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if v.is_integer() and abs(v) < 1e15:
            return str(int(v))
        return repr(v)
    if isinstance(v, (list, tuple)):
        return ",".join(_format(x) for x in v)
    if isinstance(v, str) and _HEX.match(v):
        return v[1:]
    return str(v)


def _parse(ann: Any, text: str) -> Any:
    """Convert one query value to what the annotation expects; on doubt return the text
    and let pydantic report the problem."""
    ann = _unwrap(ann)
    origin = get_origin(ann)
    if origin in (tuple, list):
        args = get_args(ann)
        elem = args[0] if args else str
        return [_parse(elem, part) for part in text.split(",")] if text else []
    if origin is Literal:
        for lit in get_args(ann):
            if str(lit) == text:
                return lit
        return text
    if ann is bool:
        return {"true": True, "1": True, "false": False, "0": False}.get(text.lower(), text)
    if ann in (int, float) and not _NUMBER.fullmatch(text):
        return text   # Python would read '１６', '1_6' or ' 16 ': a URL number is ASCII only
    if ann is int:
        try:
            return int(text)
        except ValueError:
            return text
    if ann is float:
        try:
            return float(text)
        except ValueError:
            return text
    return text


# ---------------------------------------------------------------- encode


def _diff(cls: type[BaseModel], value: dict, base: dict, prefix: str, out: list[tuple[str, str]]):
    for name, field in cls.model_fields.items():
        if name not in value:
            continue
        v, b = value[name], base.get(name) if isinstance(base, dict) else None
        key = f"{prefix}{name}"
        ann = _unwrap(field.annotation)
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            _diff(ann, v, b or {}, key + ".", out)
            continue
        item_ann = _list_arg(ann)
        if item_ann is not None and v and isinstance(v[0], dict):
            if v == b:
                continue
            out.append((key, str(len(v))))
            for i, item in enumerate(v):
                icls = _item_class(item_ann, item)
                idef = icls().model_dump(mode="json")
                if "kind" in idef:   # always written: it chooses the item's class
                    out.append((f"{key}.{i}.kind", str(item["kind"])))
                _diff(icls, item, idef, f"{key}.{i}.", out)
            continue
        if item_ann is not None and not v and b and isinstance(b[0], dict):
            out.append((key, "0"))   # an emptied list of objects
            continue
        if v != b:
            out.append((key, _format(v)))


def encode(params: FogParams, base: str = "default") -> str:
    """The canonical query string of `params`, written against the preset `base`."""
    cls = type(params)
    value = params.model_dump(mode="json")
    basis = P.preset_dict(base)
    if cls is StillParams:
        basis = {**basis, "width": StillParams.model_fields["width"].default,
                 "height": StillParams.model_fields["height"].default}
    pairs: list[tuple[str, str]] = [("v", str(VERSION))]
    if base != "default":
        pairs.append(("preset", base))
    _diff(cls, value, basis, "", pairs)
    return "&".join(f"{k}={quote(v, safe=_SAFE)}" for k, v in pairs)


def encode_field(params: FogParams, name: str, base: str = "default") -> str:
    """The keys of `encode(params, base)` under the top-level field `name` (for example
    every `camera.` key), in the same order and form: the part of the canonical query that a
    change of that field alone changes. A client splices it into the query it holds."""
    pairs: list[tuple[str, str]] = []
    _diff(type(params), {name: getattr(params, name).model_dump(mode="json")}, P.preset_dict(base), "", pairs)
    return "&".join(f"{k}={quote(v, safe=_SAFE)}" for k, v in pairs)


# ---------------------------------------------------------------- compact form


def _pairs(query: str) -> list[tuple[str, str]]:
    if len(query) > MAX_QUERY:
        raise URLError([error(["query"], f"query longer than {MAX_QUERY} characters", "url_too_long")])
    try:
        return parse_qsl(query, keep_blank_values=True, strict_parsing=bool(query), max_num_fields=1000)
    except ValueError as exc:
        raise URLError([error(["query"], f"malformed query string: {exc}", "url_malformed")]) from None


def _bad_z(msg: str, kind: str = "url_compact") -> URLError:
    return URLError([error(["query", "z"], f"{msg}; z is the base64url text (A-Z a-z 0-9 - _, no "
                           f"padding, at most {MAX_COMPACT} characters) of the raw deflate of a "
                           f"readable query of at most {MAX_QUERY} characters", kind)])


def inflate(z: str) -> str:
    """The readable query inside a `z` value; URLError naming `z` if there is none. The
    inflated size is bounded as it is made: a small `z` that would inflate to gigabytes
    costs no more than one that inflates to MAX_QUERY + 1 bytes."""
    if len(z) > MAX_COMPACT:
        raise _bad_z(f"z is {len(z)} characters long", "url_too_long")
    if not _BASE64URL.fullmatch(z) or len(z) % 4 == 1:
        raise _bad_z("z is not base64url")
    try:
        data = base64.b64decode(z + "=" * (-len(z) % 4), altchars=b"-_", validate=True)
    except ValueError:
        raise _bad_z("z is not base64url") from None
    d = zlib.decompressobj(wbits=-15)
    try:
        raw = d.decompress(data, MAX_QUERY + 1)
    except zlib.error as exc:
        raise _bad_z(f"z does not inflate ({exc})") from None
    if len(raw) > MAX_QUERY or d.unconsumed_tail:
        raise _bad_z(f"z inflates to more than {MAX_QUERY} bytes", "url_too_long")
    if not d.eof:
        raise _bad_z("z is a truncated deflate stream")
    if d.unused_data:
        raise _bad_z("z has bytes after its deflate stream")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise _bad_z("z inflates to bytes that are not UTF-8") from None


def _key(part: str) -> str:
    return unquote_plus(part.split("=", 1)[0])


def _readable_pairs(query: str, lenient: list[dict[str, Any]] | None = None) -> list[tuple[str, str]]:
    """The (key, value) pairs of a query, a compact one's `z` inflated and read as a
    readable query, followed by the keys beside it. A key beside `z` that is not one of
    BESIDE_Z is an error naming it; with `lenient` (a list) that key is left out and its
    error appended there. Raises URLError for an over-long or malformed query or `z`."""
    pairs = _pairs(query)
    zs = [v for k, v in pairs if k == "z"]
    if not zs:
        return pairs
    if len(zs) > 1:
        raise URLError([error(["query", "z"], "given more than once", "url_duplicate")])
    beside = [(k, v) for k, v in pairs if k in BESIDE_Z]
    errors = [error(["query", k], f"may not stand beside z (only {', '.join(BESIDE_Z)} may: the "
                    "rest of the look is inside z)", "url_compact")
              for k, _ in pairs if k != "z" and k not in BESIDE_Z]
    if errors and lenient is None:
        raise URLError(errors)
    inner = _pairs(inflate(zs[0]))
    if any(k == "z" for k, _ in inner):
        raise _bad_z("z inflates to a query that holds a z of its own")
    if lenient is not None:
        lenient += errors
    return inner + beside


def compact(query: str) -> str:
    """The compact form of a readable query: `z=` and the rest of the look deflated, with
    the keys of BESIDE_Z kept readable beside it (as the page's links.js makes it)."""
    parts = [p for p in query.split("&") if p]
    inside = "&".join(p for p in parts if _key(p) not in BESIDE_Z)
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    z = base64.urlsafe_b64encode(c.compress(inside.encode()) + c.flush()).rstrip(b"=").decode()
    return "&".join([f"z={z}", *(p for p in parts if _key(p) in BESIDE_Z)])


def shareable(query: str) -> str:
    """A query as a link gives it: readable up to LONG_QUERY characters, else compact."""
    return query if len(query) <= LONG_QUERY else compact(query)


# ---------------------------------------------------------------- decode


def _field_ann(cls: type[BaseModel] | None, name: str) -> Any:
    if cls is None or name not in cls.model_fields:
        return None
    return cls.model_fields[name].annotation


def _fields(query: str, lenient: bool) -> tuple[dict[str, str], str, list[dict[str, Any]]]:
    """(the look's fields, the base preset, errors) of a query (a compact one inflated):
    page-only keys removed, `v` and `preset` read. Raises URLError for an over-long or
    malformed query or `z`. With `lenient`, a bad version or preset is read as this
    version and "default", and a key that may not stand beside `z` is left out."""
    errors: list[dict[str, Any]] = []
    pairs = _readable_pairs(query, errors if lenient else None)
    fields: dict[str, str] = {}
    for k, v in pairs:
        if k in fields:
            _err(errors, k, "given more than once" + ("; the last is used" if lenient else ""), "url_duplicate")
        fields[k] = v
    for key in VIEW_KEYS:
        fields.pop(key, None)
    version = fields.pop("v", str(VERSION))
    if version != str(VERSION):
        _err(errors, "v", f"unknown URL version {version!r}; " +
             (f"read as version {VERSION}" if lenient else f"this server reads version {VERSION}"),
             "url_version")
    base = fields.pop("preset", "default")
    if base not in P.presets():
        _err(errors, "preset", f"unknown preset {base!r}; one of {', '.join(P.presets())}" +
             ("; the rest is applied to 'default'" if lenient else ""), "url_preset")
        base = "default"
    return fields, base, errors


def _base_value(base: str, cls: type[FogParams]) -> dict:
    value: dict = P.preset_dict(base)
    if cls is StillParams:
        value = {**value, "width": StillParams.model_fields["width"].default,
                 "height": StillParams.model_fields["height"].default}
    return value


def decode(query: str, cls: type[FogParams] = FogParams) -> tuple[dict, str]:
    """Query string -> (params dict ready for validation, base preset name).

    The dict is the base preset with the query's fields patched in; validating it with
    `cls` gives the params. Raises URLError for a malformed query.
    """
    fields, base, errors = _fields(query, lenient=False)
    if errors:
        raise URLError(errors)
    value = _base_value(base, cls)
    # shallow keys first, and an item's `kind` before its other fields, so that lists
    # exist and items are filled from their class's defaults before fields are patched
    for key in sorted(fields, key=lambda k: (k.count("."), not k.endswith(".kind"), k)):
        _set(cls, value, key, fields[key], errors)
    if errors:
        raise URLError(errors)
    return value, base


def decode_lenient(query: str, cls: type[FogParams] = FogParams) -> tuple[FogParams, list[dict[str, Any]]]:
    """The look of a query with its bad parts left out: (the params, one error per part
    left out). A link with one bad key or value keeps the rest of its look: an unknown
    preset falls back to "default", an unknown URL version is read as this one, and each
    field that does not parse or validate is dropped (with the fields under it). Raises
    URLError only when nothing can be read: an over-long or malformed query, or an error
    that no single field of the query caused."""
    fields, base, errors = _fields(query, lenient=True)
    for _ in range(16):   # each round drops at least one field
        value = _base_value(base, cls)
        bad: list[dict[str, Any]] = []
        for key in sorted(fields, key=lambda k: (k.count("."), not k.endswith(".kind"), k)):
            _set(cls, value, key, fields[key], bad)
        for e in bad:
            fields.pop(e["loc"][1], None)
        errors += bad
        try:
            return cls.model_validate(value), errors
        except ValidationError as exc:
            dropped = False
            for e in exc.errors(include_url=False):
                # a layer's loc names its kind after the index (the union's tag): not a key
                loc = [x for i, x in enumerate(e["loc"])
                       if not (i and isinstance(e["loc"][i - 1], int) and x in LAYER_CLASSES)]
                at = ".".join(str(x) for x in loc)
                # the field itself and those under it; else the nearest field above it
                # (a vector given whole: camera.position for camera.position.0)
                keys = [k for k in fields if at and (k == at or k.startswith(at + "."))]
                if not keys:
                    keys = sorted((k for k in fields if at.startswith(k + ".")), key=len)[-1:]
                if not keys:
                    raise URLError([error(["query", at], e["msg"], e["type"])]) from None
                for k in keys:
                    _err(errors, k, e["msg"], e["type"])
                    fields.pop(k)
                    dropped = True
            if not dropped:
                break
    raise URLError(errors)


def _err(errors, key, msg, kind="url_field"):
    errors.append(error(["query", key], msg, kind))


def _set(cls, value, key, text, errors) -> None:
    """Patch one query field into the nested dict `value`, converting by the model's types."""
    parts = key.split(".")
    node: Any = value
    ncls: Any = cls          # model class of a dict node; item annotation of a list node
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                _err(errors, key, f"index {part!r} is out of range: set "
                     f"{'.'.join(parts[:i])}=<count> first", "url_index")
                return
            if last:
                _err(errors, key, "a list item is set field by field")
                return
            node = node[int(part)]
            ncls = _item_class(ncls, node)
            if ncls is None and not (parts[i + 1] == "kind" and i + 1 == len(parts) - 1):
                _err(errors, key, f"set {'.'.join(parts[:i + 1])}.kind first", "url_kind")
                return
            continue
        if part == "kind" and last and isinstance(node, dict) and (
                not node or ("kind" in node and node["kind"] != text)):
            # a new (or re-kinded) layer: `kind` picks its class and fills its defaults
            if text not in LAYER_CLASSES:
                _err(errors, key, f"unknown layer kind {text!r}; one of {', '.join(LAYER_CLASSES)}",
                     "url_kind")
                return
            node.clear()
            node.update(LAYER_CLASSES[text]().model_dump(mode="json"))
            return
        if not isinstance(node, dict) or ncls is None:
            _err(errors, key, "no such field")
            return
        ann = _field_ann(ncls, part)
        if ann is None:
            if last:
                node[part] = text   # unknown: validation names it ("extra inputs")
            else:
                _err(errors, key, "no such field")
            return
        item_ann = _list_arg(ann)
        is_object_list = item_ann is not None and (
            get_origin(_unwrap(item_ann)) is Union or _item_class(item_ann, {}) is not None)
        if last:
            if is_object_list:
                if not text.isdigit() or int(text) > MAX_LIST:
                    _err(errors, key, f"a list length is an integer 0..{MAX_LIST}", "url_count")
                    return
                # items start from their class's defaults; in a union (layers) from its
                # first class's, until `.N.kind` picks another
                fixed = _item_class(item_ann, {}) or _first_class(item_ann)
                node[part] = [fixed().model_dump(mode="json") if fixed else {}
                              for _ in range(int(text))]
            else:
                node[part] = _parse(ann, text)
            return
        if part not in node:
            _err(errors, key, "no such field")
            return
        node = node[part]
        unwrapped = _unwrap(ann)
        ncls = item_ann if is_object_list else (
            unwrapped if isinstance(unwrapped, type) and issubclass(unwrapped, BaseModel) else None)


def view_state(query: str) -> dict[str, Any]:
    """The page-only keys of a query (a compact one inflated): {"playing": bool,
    "speed": float} where given. Values that do not parse are ignored (they never change
    the look)."""
    out: dict[str, Any] = {}
    try:
        pairs = _readable_pairs(query, [])
    except URLError:   # unreadable: the keys beside an unreadable z still say how to play
        pairs = parse_qsl(query, keep_blank_values=True)
    for k, v in pairs:
        if k == "play" and v in ("0", "1"):
            out["playing"] = v == "1"
        elif k == "speed":
            try:
                f = float(v)
            except ValueError:
                continue
            if -100 <= f <= 100:
                out["speed"] = f
    return out


def view_suffix(playing: bool, speed: float) -> str:
    """The page-only keys that differ from the defaults (playing at speed 1)."""
    out = "" if playing else "&play=0"
    if speed != 1.0:
        out += f"&speed={_format(float(speed))}"
    return out


def canonical(query: str, cls: type[FogParams] = FogParams) -> str:
    value, base = decode(query, cls)
    return encode(cls.model_validate(value), base)
