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
    reduced: (v.getUint8(33) & 4) !== 0, fogScale: v.getUint8(34),
  };
}

export class Stream extends EventTarget {
  constructor(canvas, queryFn) {
    super();
    this.canvas = canvas;
    this.ctx2d = canvas.getContext("2d");
    this.queryFn = queryFn;          // the query to (re)connect with
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
    this.ws = new WebSocket(`${proto}//${location.host}/ws${q ? "?" + q : ""}`);
    this.ws.binaryType = "arraybuffer";
    this.ws.onopen = () => {
      this.retry = 0;
      this.connected = true;
      if (this.view) this.send({ type: "view", ...this.view });
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
    this.send({ type: "view", ...view });
  }

  async onMessage(ev) {
    if (typeof ev.data === "string") {
      const msg = JSON.parse(ev.data);
      if (msg.type === "state" || msg.type === "camera") {
        // a reply answers `answers` look changes (several collapse into one reply while
        // frames are in flight), each of which made one version, the last this one
        const n = Math.min(msg.answers ?? 1, this.sendTimes.length);
        this.sendTimes.splice(0, n).forEach((t, i) => this.versionTimes.set(msg.version - (n - 1 - i), t));
      }
      if (msg.type === "error" && this.sendTimes.length) this.sendTimes.shift();
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

  // frames per second over the last two seconds (0 once frames stop coming)
  fps() {
    const now = performance.now();
    while (this.frameTimes.length && now - this.frameTimes[0] > 2000) this.frameTimes.shift();
    const n = this.frameTimes.length;
    if (n < 2) return 0;
    return (n - 1) * 1000 / (this.frameTimes[n - 1] - this.frameTimes[0]);
  }
}
