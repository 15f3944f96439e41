// The WebSocket client: connects to /ws with the page's query, draws frames on a canvas,
// acknowledges them, measures fps and input-to-frame latency, and reconnects by itself.
// Frames are drawn in the order they arrived (over one WebSocket, the order the server
// sent them): decoding is async, and a frame whose decode ends after a newer frame was
// drawn is dropped, never drawn over it.

import { compactQuery, isLong } from "./links.js";

const HEADER_BYTES = 36;
const RETRY_CODES = new Set([1006, 1011, 1012, 1013]);

export function parseHeader(buf) {
  const v = new DataView(buf);
  const magic = String.fromCharCode(v.getUint8(0), v.getUint8(1), v.getUint8(2), v.getUint8(3));
  if (magic !== "FBK1") throw new Error(`bad frame magic ${magic}`);
  return {
    frame: v.getUint32(4, true), version: v.getUint32(8, true), time: v.getFloat64(12, true),
    renderMs: v.getFloat32(20, true), encodeMs: v.getFloat32(24, true),
    width: v.getUint16(28, true), height: v.getUint16(30, true), quality: v.getUint8(32),
    full: (v.getUint8(33) & 1) !== 0, playing: (v.getUint8(33) & 2) !== 0,
    reduced: (v.getUint8(33) & 4) !== 0, key: (v.getUint8(33) & 8) !== 0, fogScale: v.getUint8(34),
    codec: CODEC_NAMES[v.getUint8(35)] || "jpeg",
  };
}

// The header's codec byte (server/fogbank/stream/protocol.py CODEC_IDS), and the WebCodecs
// codec string of each video codec (VP9 profile 0, level 4.1, 8 bits)
const CODEC_NAMES = ["jpeg", "vp8", "vp09"];
const CODEC_STRINGS = { vp09: "vp09.00.41.08", vp8: "vp8" };

// What this browser decodes, most wanted first, for the view message: the video codecs that
// WebCodecs' VideoDecoder supports (only in a secure context: HTTPS or localhost), then JPEG
export async function decodableCodecs() {
  if (!window.isSecureContext || typeof VideoDecoder === "undefined") return ["jpeg"];
  const out = [];
  for (const [name, codec] of Object.entries(CODEC_STRINGS)) {
    try {
      const { supported } = await VideoDecoder.isConfigSupported({ codec, optimizeForLatency: true });
      if (supported) out.push(name);
    } catch { /* not this one */ }
  }
  return [...out, "jpeg"];
}

export class Stream extends EventTarget {
  constructor(canvas, queryFn) {
    super();
    this.canvas = canvas;
    this.ctx2d = canvas.getContext("2d");
    this.queryFn = queryFn;          // the query to (re)connect with
    this.extra = "";                 // beside it, never compacted (a live session's room or token)
    this.ws = null;
    this.retry = 0;
    this.frameTimes = [];
    this.sendTimes = [];             // wall times of look changes awaiting their state reply
    this.versionTimes = new Map();   // params version -> when its change was sent
    this.latency = null;
    this.lastFrame = null;
    this.view = null;
    this.connected = false;
    this.received = 0;               // binary frames received, counted in arrival order
    this.drawn = 0;                  // the arrival number of the frame on the canvas
    this.decode = (blob) => createImageBitmap(blob);   // blob -> ImageBitmap (tests may swap it)
    this.codecs = ["jpeg"];          // what the page decodes (decodableCodecs), sent with the view
    this.decoder = null;             // the VideoDecoder of video frames, and its codec and size
    this.decoderKey = "";
    this.videoMeta = new Map();      // a video frame's header and arrival, by its timestamp (frame id)
    this.videoError = null;          // why video stopped (the page then asks for JPEG)
  }

  // The codecs to ask for: sent with the view (at once, if it is known)
  setCodecs(codecs) {
    this.codecs = codecs;
    if (this.view) this.send({ type: "view", ...this.view, codecs });
  }

  // A long look connects with its compact link (links.js): a 12k-character /ws request
  // line was refused (a black view), and proxies cap request lines too.
  connect() {
    const q = this.queryFn();
    if (!isLong(q)) return this.open(q);
    return compactQuery(q).then((z) => this.open(z), () => this.open(q));
  }

  open(q) {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    if (this.extra) q = q ? `${q}&${this.extra}` : this.extra;
    this.ws = new WebSocket(`${proto}//${location.host}/ws${q ? "?" + q : ""}`);
    this.ws.binaryType = "arraybuffer";
    this.ws.onopen = () => {
      this.retry = 0;
      this.connected = true;
      if (this.view) this.send({ type: "view", ...this.view, codecs: this.codecs });
      this.dispatchEvent(new CustomEvent("open"));
    };
    this.ws.onmessage = (ev) => this.onMessage(ev);
    this.ws.onclose = (ev) => {
      this.connected = false;
      this.sendTimes = [];
      this.dispatchEvent(new CustomEvent("close", { detail: { code: ev.code, reason: ev.reason } }));
      if (RETRY_CODES.has(ev.code) || ev.code === 1001 || ev.code === 1005) {
        // 250, 500, then every second: back within about a second of the server's return
        const delay = Math.min(1000, 250 * 2 ** this.retry++);
        this.dispatchEvent(new CustomEvent("reconnecting", { detail: { delay, code: ev.code } }));
        setTimeout(() => this.connect(), delay);
      }
    };
  }

  send(msg) {
    if (!this.ws || this.ws.readyState !== WebSocket.OPEN) return false;
    if (msg.type === "params" || msg.type === "camera" || msg.type === "query" || msg.type === "seek") {
      this.sendTimes.push(performance.now());
    }
    this.ws.send(JSON.stringify(msg));
    return true;
  }

  setView(view) {
    this.view = view;
    this.send({ type: "view", ...view, codecs: this.codecs });
  }

  async onMessage(ev) {
    if (typeof ev.data === "string") {
      const msg = JSON.parse(ev.data);
      if (msg.type === "state" || msg.type === "camera") {
        // a reply answers `answers` look changes (several collapse into one reply while
        // frames are in flight), each of which made one version, the last this one
        const n = Math.min(msg.answers ?? 0, this.sendTimes.length);
        this.sendTimes.splice(0, n).forEach((t, i) => this.versionTimes.set(msg.version - (n - 1 - i), t));
      }
      if (msg.type === "error") this.sendTimes.splice(0, msg.answers ?? 0);   // a refused look change
      if (msg.type === "ping") {   // at once: the server measures the link's round trip by it
        this.send({ type: "pong", ping: msg.ping });
        return;
      }
      this.dispatchEvent(new CustomEvent(msg.type, { detail: msg }));
      return;
    }
    const header = parseHeader(ev.data);
    // the arrival number orders frames across reconnects too (a new session's frame ids
    // start again from 1)
    const seq = ++this.received;
    this.send({ type: "ack", frame: header.frame });
    const now = performance.now();
    for (const [version, t] of this.versionTimes) {
      if (version <= header.version) {
        this.latency = now - t;
        this.versionTimes.delete(version);
      }
    }
    this.frameTimes.push(now);
    while (this.frameTimes.length && now - this.frameTimes[0] > 2000) this.frameTimes.shift();
    if (header.codec !== "jpeg") {
      this.decodeVideo(header, ev.data, seq, now);
      return;
    }
    const blob = new Blob([new Uint8Array(ev.data, HEADER_BYTES)], { type: "image/jpeg" });
    const bitmap = await this.decode(blob);
    if (seq < this.drawn) {   // a newer frame was decoded first and is on the canvas already
      bitmap.close();
      return;
    }
    this.drawn = seq;
    if (this.canvas.width !== bitmap.width || this.canvas.height !== bitmap.height) {
      this.canvas.width = bitmap.width;
      this.canvas.height = bitmap.height;
    }
    this.ctx2d.drawImage(bitmap, 0, 0);
    bitmap.close();
    this.lastFrame = { ...header, bytes: ev.data.byteLength, at: now };
    this.dispatchEvent(new CustomEvent("frame", { detail: this.lastFrame }));
  }

  // A video frame (VP9 or VP8): decoded by WebCodecs in order, drawn when its picture comes
  // out (decoderOutput). A keyframe (re)opens the decoder for its codec and size; a delta
  // frame with no decoder open waits for the next keyframe (the server sends one for a new
  // session, a new size and a dropped frame).
  decodeVideo(header, buf, seq, now) {
    const key = `${header.codec} ${header.width}x${header.height}`;
    if (header.key && (!this.decoder || this.decoder.state === "closed" || this.decoderKey !== key)) {
      if (this.decoder && this.decoder.state !== "closed") this.decoder.close();
      this.decoder = new VideoDecoder({
        output: (frame) => this.decoderOutput(frame),
        error: (e) => this.videoFailed(e),
      });
      try {
        this.decoder.configure({ codec: CODEC_STRINGS[header.codec], codedWidth: header.width,
          codedHeight: header.height, optimizeForLatency: true });
      } catch (e) {
        this.videoFailed(e);
        return;
      }
      this.decoderKey = key;
    }
    if (!this.decoder || this.decoder.state !== "configured" || this.decoderKey !== key) return;
    this.videoMeta.set(header.frame, { header, seq, bytes: buf.byteLength, at: now });
    try {
      this.decoder.decode(new EncodedVideoChunk({ type: header.key ? "key" : "delta", timestamp: header.frame,
        data: new Uint8Array(buf, HEADER_BYTES) }));
    } catch (e) {
      this.videoFailed(e);
    }
  }

  decoderOutput(frame) {
    const meta = this.videoMeta.get(frame.timestamp);
    for (const t of this.videoMeta.keys()) if (t <= frame.timestamp) this.videoMeta.delete(t);
    if (!meta || meta.seq < this.drawn) {   // a newer frame is on the canvas already
      frame.close();
      return;
    }
    this.drawn = meta.seq;
    if (this.canvas.width !== frame.displayWidth || this.canvas.height !== frame.displayHeight) {
      this.canvas.width = frame.displayWidth;
      this.canvas.height = frame.displayHeight;
    }
    this.ctx2d.drawImage(frame, 0, 0);
    frame.close();
    this.lastFrame = { ...meta.header, bytes: meta.bytes, at: meta.at };
    this.dispatchEvent(new CustomEvent("frame", { detail: this.lastFrame }));
  }

  // After a decode error, JPEG from then on: the server is told with the view
  videoFailed(e) {
    this.videoError = String(e && e.message || e);
    if (this.decoder && this.decoder.state !== "closed") this.decoder.close();
    this.decoder = null;
    this.setCodecs(["jpeg"]);
    this.dispatchEvent(new CustomEvent("videoerror", { detail: this.videoError }));
  }

  // frames per second over the last two seconds (0 once frames stop coming)
  fps() {
    const now = performance.now();
    while (this.frameTimes.length && now - this.frameTimes[0] > 2000) this.frameTimes.shift();
    const n = this.frameTimes.length;
    if (n < 2) return 0;
    return (n - 1) * 1000 / (this.frameTimes[n - 1] - this.frameTimes[0]);
  }
}
