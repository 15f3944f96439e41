// fogbank's live page: wires the stream, the schema-built controls, camera input, the
// toolbar and the URL (which follows the look through history.replaceState).

import { Stream } from "./stream.js";
import { Controls, buildPatch } from "./controls.js";
import { CameraInput } from "./camera.js";

const $ = (id) => document.getElementById(id);
const canvas = $("view");

const [schema, presets] = await Promise.all([
  fetch("/api/schema").then((r) => r.json()),
  fetch("/api/presets").then((r) => r.json()),
]);

let params = null;            // the look as the server last confirmed it (plus local camera moves)
let version = 0;
let playing = true;
let redrawNext = true;        // redraw the form when the next state arrives
let interacting = false;
let scrubbing = false;
let simTime = 0;

// ------------------------------------------------------------------ stream
const stream = new Stream(canvas, () => location.search.slice(1));
window.fogbank = { stream, get params() { return params; }, get version() { return version; } };

// Patches are merged and sent at most once per animation frame.
let pendingParams = null;
let pendingCamera = null;
let flushQueued = false;
function merge(a, b) {
  if (a && b && typeof a === "object" && typeof b === "object" && !Array.isArray(a) && !Array.isArray(b)) {
    const out = { ...a };
    for (const [k, v] of Object.entries(b)) out[k] = k in a ? merge(a[k], v) : v;
    return out;
  }
  return b;
}
function queueFlush() {
  if (flushQueued) return;
  flushQueued = true;
  requestAnimationFrame(() => {
    flushQueued = false;
    if (pendingParams) stream.send({ type: "params", params: pendingParams });
    if (pendingCamera) stream.send({ type: "camera", camera: pendingCamera });
    pendingParams = pendingCamera = null;
  });
}

function setInteract(active) {
  if (active === interacting) return;
  interacting = active;
  stream.send({ type: "interact", active });
}

// ------------------------------------------------------------------ controls
const controls = new Controls($("controls"), schema, (path, value) => {
  const patch = buildPatch(params, path, value);
  // a list added to, removed from or reordered, or a layer toggled, changes the form
  const structural = (Array.isArray(value) && (value.length === 0 || typeof value[0] === "object"))
    || path.at(-1) === "enabled";
  if (structural) redrawNext = true;
  params = merge(params, patch);
  pendingParams = merge(pendingParams || {}, patch);
  queueFlush();
});
controls.onChange.interact = setInteract;

// ------------------------------------------------------------------ camera
new CameraInput(canvas, () => params.camera, (patch) => {
  params = { ...params, camera: { ...params.camera, ...patch } };
  pendingCamera = { ...(pendingCamera || {}), ...patch };
  queueFlush();
}, setInteract);

// ------------------------------------------------------------------ server messages
stream.addEventListener("hello", (e) => { $("stat-renderer").textContent = e.detail.renderer; });
stream.addEventListener("state", (e) => {
  const s = e.detail;
  version = s.version;
  playing = s.playing;
  if (!interacting || !params) params = s.params;
  else params = { ...s.params, camera: params.camera };   // keep the camera being dragged
  const q = s.query === "v=1" ? "" : s.query;
  if (location.search.slice(1) !== q) history.replaceState(null, "", q ? `?${q}` : location.pathname);
  $("play").textContent = playing ? "Pause" : "Play";
  $("play").setAttribute("aria-pressed", String(playing));
  $("speed").value = String(s.speed);
  const look = s.query.replace(/&(play|speed)=[^&]*/g, "");
  const match = presets.find((p) => p.query === look);
  $("preset").value = match ? match.name : "";
  if (redrawNext) { controls.render(params); redrawNext = false; }
});
stream.addEventListener("error", (e) => {
  toast(e.detail.msg || "error");
  redrawNext = true;   // the server kept its last valid look: show it again
  stream.send({ type: "params", params: {} });
});
stream.addEventListener("frame", (e) => {
  simTime = e.detail.time;
  if (!scrubbing) {
    const t = $("time");
    if (simTime > Number(t.max)) t.max = String(Math.ceil(simTime / 600) * 600);
    t.value = String(simTime);
  }
  $("time-out").textContent = `${simTime.toFixed(1)} s`;
  canvas.dataset.frame = String(e.detail.frame);
  canvas.dataset.version = String(e.detail.version);
  canvas.dataset.full = String(e.detail.full);
  canvas.dataset.frames = String(Number(canvas.dataset.frames || 0) + 1);
});
stream.addEventListener("reconnecting", () => banner("Connection lost — reconnecting…"));
stream.addEventListener("close", (e) => {
  if (e.detail.code === 1009) banner("Disconnected: a message was too large.");
  if (e.detail.code === 4408) {   // the server closed a quiet session: resume on the next input
    banner(`Paused by the server (${e.detail.reason || "idle"}). Click or press a key to resume.`);
    const resume = () => {
      removeEventListener("pointerdown", resume, true);
      removeEventListener("keydown", resume, true);
      banner("Reconnecting…");
      stream.connect();
    };
    addEventListener("pointerdown", resume, true);
    addEventListener("keydown", resume, true);
  }
});
stream.addEventListener("open", () => { banner(null); redrawNext = true; sendView(); });

// ------------------------------------------------------------------ toolbar
for (const p of presets) $("preset").append(new Option(p.title, p.name));
$("preset").append(new Option("(custom)", ""));
$("preset").addEventListener("change", () => {
  const p = presets.find((x) => x.name === $("preset").value);
  if (!p) return;
  redrawNext = true;
  stream.send({ type: "query", query: p.query });
});
$("play").addEventListener("click", () => stream.send({ type: "play", playing: !playing }));
$("speed").addEventListener("change", () => stream.send({ type: "speed", speed: Number($("speed").value) }));
$("time").addEventListener("input", () => {
  scrubbing = true;
  $("time-out").textContent = `${Number($("time").value).toFixed(1)} s`;
  stream.send({ type: "seek", time: Number($("time").value) });
});
$("time").addEventListener("change", () => { scrubbing = false; });
$("copy-link").addEventListener("click", async () => {
  try {
    await navigator.clipboard.writeText(location.href);
    toast("Link copied");
  } catch {
    prompt("Copy this link", location.href);
  }
});
$("download").addEventListener("click", () => {
  const [w, h] = $("still-size").value.split("x").map(Number);
  const q = new URLSearchParams(location.search);
  q.set("time", String(Math.round(simTime * 1000) / 1000));
  q.set("width", String(w));
  q.set("height", String(h));
  const a = document.createElement("a");
  a.href = `/api/still.png?${q}`;
  a.download = `fogbank-${w}x${h}.png`;
  document.body.append(a);
  a.click();
  a.remove();
});
$("stream-size").addEventListener("change", sendView);
$("toggle-panel").addEventListener("click", () => {
  const hidden = document.body.classList.toggle("panel-hidden");
  $("toggle-panel").setAttribute("aria-expanded", String(!hidden));
  sendView();
});
let resizeTimer = 0;
addEventListener("resize", () => { clearTimeout(resizeTimer); resizeTimer = setTimeout(sendView, 150); });

function sendView() {
  const stage = $("stage");
  const aspect = Math.max(0.5, Math.min(3, stage.clientWidth / Math.max(1, stage.clientHeight)));
  let height = Number($("stream-size").value);
  let width = Math.round(height * aspect / 2) * 2;
  if (width > 1920) { width = 1920; height = Math.round(1920 / aspect / 2) * 2; }
  stream.setView({ width, height, fps: 60, quality: 80 });
}

// ------------------------------------------------------------------ overlay
function banner(text) {
  const b = $("banner");
  b.hidden = !text;
  b.textContent = text || "";
}
let toastTimer = 0;
function toast(text) {
  const t = $("toast");
  t.textContent = text;
  t.hidden = false;
  clearTimeout(toastTimer);
  toastTimer = setTimeout(() => { t.hidden = true; }, 4000);
}
setInterval(() => {
  $("stat-fps").textContent = `${stream.fps().toFixed(1)} fps`;
  $("stat-latency").textContent = stream.latency == null ? "– ms" : `${Math.round(stream.latency)} ms`;
  $("stat-size").textContent = stream.lastFrame ? `${(stream.lastFrame.bytes / 1024).toFixed(0)} KB` : "– KB";
}, 250);

if (innerWidth < 900) {   // phones and narrow windows start with the view, not the panel
  document.body.classList.add("panel-hidden");
  $("toggle-panel").setAttribute("aria-expanded", "false");
}
sendView();
stream.connect();
