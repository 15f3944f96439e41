"""The WebSocket protocol: client messages (JSON text) and the binary frame header.

Client -> server, one JSON object per text message, told apart by "type":

    {"type": "query", "query": "v=1&camera.yaw=12"}        set the look from a URL query
    {"type": "params", "params": {...}, "replace": false}  patch (or replace) the look
    {"type": "camera", "camera": {"yaw": 10}}              patch the camera
    {"type": "play", "playing": true}                      run or stop the clock
    {"type": "speed", "speed": 2.0}                        time speed (sim s per wall s)
    {"type": "seek", "time": 12.5}                         set the sim time
    {"type": "view", "width": 640, "height": 360, "fps": 30, "quality": 80,
     "show": "shaded", "layer": 0, "codecs": ["vp09", "jpeg"]}
                                                           size, rate, what the frames show,
                                                           and what the client decodes
    {"type": "interact", "active": true}                   a drag started/ended
    {"type": "ack", "frame": 17}                           frames up to 17 arrived
    {"type": "pong", "ping": 3}                            the answer to ping 3, at once
    {"type": "share", "active": true}                      share this session live (or stop)
    {"type": "control", "to": "a1b2c3"}                    hand control to a viewer (null:
                                                           back to the presenter)

Server -> client: text {"type": "hello" | "state" | "camera" | "error" | "view_stats" | "ping"
| "link", ...} and
binary frames (a view that teaches, render/teach.py, sends its numbers and legend as
"view_stats" just before its frame):
HEADER (little-endian, 36 bytes) followed by the JPEG, or a VP9 or VP8 packet (the
header's codec byte; a keyframe has FLAG_KEY).

    {"type": "state", "version": 7, "query": "...", "params": {...}, "playing": true,
     "speed": 1.0, "time": 3.2, "view": {...}, "answers": 2}        the whole look
    {"type": "camera", "version": 8, "camera": {...}, "query": "camera.yaw=12",
     "answers": 1}                                 a camera message's reply: the camera alone

    {"type": "ping", "ping": 3}                    answer with a pong: the link's round trip
    {"type": "link", "rate_bps": 4.8e6, "rtt_ms": 41, "stream_bps": 1.2e6, "limiting": true}
                                                   the link as the server measures it (stream/link.py)

    {"type": "audience", "role": "presenter", "token": "...", "viewers": 3, "ids": [...],
     "control": null, "you": null}                 who watches a live session and who controls it
    {"type": "ended", "msg": "..."}                a live session ended (then closed, code 4410)

A live session (stream/live.py): the presenter's page connects with `room=<token>` beside
its look (the key its load balancer routes by), and "share" makes that token the live
link; viewers connect with `live=<token>` alone and get the presenter's frames, state and
"audience" messages. A viewer's look changes apply only while it has control.

A reply to look changes waits while the socket's window of frames is unacknowledged (two,
and those one round trip holds: session.py Session.window); the changes
made meanwhile collapse into one reply, which `answers` of them (query, params, camera,
seek messages; 0 for play and speed).
"""

from __future__ import annotations

import json
import struct
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from fogbank.model.errors import clean, error, from_validation
from fogbank.model.fields import MAX_LAYERS, Int
from fogbank.model.urlstate import MAX_QUERY

# 3: live sessions (share, control, audience, ended)
# 2: the camera reply, replies that wait in the window ("answers"), ping/pong and "link",
# video frames (the header's codec byte, FLAG_KEY; the view's "codecs")
PROTOCOL = 3
MAX_MESSAGE = 64 * 1024
# magic, frame id, params version, sim time (s), render ms, encode ms, width, height,
# jpeg quality, flags (bit 0: full quality, bit 1: playing, bit 2: reduced, bit 3: a
# keyframe), fog scale, codec (CODEC_IDS)
HEADER = struct.Struct("<4sIIdffHHBBBB")
MAGIC = b"FBK1"
FLAG_FULL = 1
FLAG_PLAYING = 2
FLAG_REDUCED = 4   # a full (final) frame drawn below the look's quality: it costs past the budget
FLAG_KEY = 8       # a video frame that is a keyframe (JPEG frames stand alone and carry no flag)
# the codec of a frame's bytes: the header's last byte (render/video.py for the video codecs)
CODEC_IDS = {"jpeg": 0, "vp8": 1, "vp09": 2}
Codec = Literal["vp09", "vp8", "jpeg"]


class _Msg(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class QueryMsg(_Msg):
    type: Literal["query"]
    query: str = Field(max_length=MAX_QUERY)


class ParamsMsg(_Msg):
    type: Literal["params"]
    params: dict[str, Any]
    replace: bool = False


class CameraMsg(_Msg):
    type: Literal["camera"]
    camera: dict[str, Any]


class PlayMsg(_Msg):
    type: Literal["play"]
    playing: bool


class SpeedMsg(_Msg):
    type: Literal["speed"]
    speed: float = Field(ge=-100, le=100)


class SeekMsg(_Msg):
    type: Literal["seek"]
    time: float = Field(ge=0, le=1e6)


class ViewMsg(_Msg):
    type: Literal["view"]
    width: int = Field(640, ge=16, le=1920)
    height: int = Field(360, ge=16, le=1080)
    fps: int = Field(30, ge=1, le=120)
    quality: int = Field(80, ge=10, le=95)
    # what the frames show: the shaded look, or a view that teaches (render/teach.py)
    show: Literal["shaded", "transmittance", "optical_depth", "difference"] = "shaded"
    layer: Int = Field(0, ge=0, lt=MAX_LAYERS, description="the layer whose optical depth is shown")
    # what the client decodes, most wanted first (the page asks WebCodecs' isConfigSupported);
    # the server takes the first video codec here for frames drawn while time runs, and JPEG
    # for the rest (previews, a paused look's final frame, views that teach)
    codecs: list[Codec] = Field(default_factory=lambda: ["jpeg"], max_length=8)


class InteractMsg(_Msg):
    type: Literal["interact"]
    active: bool


class AckMsg(_Msg):
    type: Literal["ack"]
    frame: int = Field(ge=0, le=2**32 - 1)


class PongMsg(_Msg):
    type: Literal["pong"]
    ping: int = Field(ge=0, le=2**32 - 1)


class ShareMsg(_Msg):
    type: Literal["share"]
    active: bool = True


class ControlMsg(_Msg):
    type: Literal["control"]
    # a viewer's id (an "audience" message's ids), or None: the presenter
    to: str | None = Field(None, max_length=64)


Message = Annotated[Union[QueryMsg, ParamsMsg, CameraMsg, PlayMsg, SpeedMsg, SeekMsg, ViewMsg,
                          InteractMsg, AckMsg, PongMsg, ShareMsg, ControlMsg], Field(discriminator="type")]
_adapter: TypeAdapter = TypeAdapter(Message)
TYPES = ["query", "params", "camera", "play", "speed", "seek", "view", "interact", "ack", "pong", "share",
         "control"]


class ProtocolError(ValueError):
    """A message the server cannot take; `errors` are {loc, msg, type} dicts."""

    def __init__(self, errors: list[dict[str, Any]]):
        super().__init__(errors[0]["msg"] if errors else "bad message")
        self.errors = errors


def parse(text: str | bytes) -> BaseModel:
    """One client message, or ProtocolError naming what is wrong with it."""
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise ProtocolError([error(["message"], "messages are UTF-8 JSON text",
                                       "message_encoding")]) from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:   # incl. integers over Python's 4300 digits
        raise ProtocolError([error(["message"], f"malformed JSON: {exc}", "json_invalid")]) from None
    if not isinstance(data, dict):
        raise ProtocolError([error(["message"], "a message is a JSON object", "message_type")])
    kind = data.get("type")
    if kind not in TYPES:
        raise ProtocolError([error(["message", "type"],
                                   f"unknown message type {kind!r}; one of {', '.join(TYPES)}",
                                   "message_type")])
    try:
        return _adapter.validate_python(data)
    except ValidationError as exc:
        raise ProtocolError([clean(dict(e, loc=["message", *e["loc"][1:]]))
                             for e in from_validation(exc)]) from None


def frame_header(frame: int, version: int, sim_time: float, render_ms: float, encode_ms: float,
                 width: int, height: int, quality: int, flags: int, fog_scale: int,
                 codec: str = "jpeg") -> bytes:
    return HEADER.pack(MAGIC, frame, version, sim_time, render_ms, encode_ms, width, height,
                       quality, flags, fog_scale, CODEC_IDS[codec])
