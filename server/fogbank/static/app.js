// fogbank's live page: wires the stream, the schema-built controls, camera input, the
// toolbar and the URL (which follows the look through history.replaceState). All of the
// page's state is in one store (store.js): handlers read it with store.get() and write it
// with store.set()/update(); the toolbar, the time slider and the canvas's data-* follow it.

import { Stream, decodableCodecs } from "./stream.js";
import { Controls, buildPatch, itemSchemaAt, keepRules } from "./controls.js";
import { UndoStack } from "./undo.js";
import { compactQuery, isLong, withCamera } from "./links.js";
import { functionEditor } from "./editor.js";
import { rayPlot } from "./rayplot.js";
import { CameraInput } from "./camera.js";
import { store, version, playing, simTime } from "./store.js";
import { canSteer, liveToken, liveUi, newRoom } from "./live.js";

const $ = (id) => document.getElementById(id);
const canvas = $("view");

const [schema, presets] = await Promise.all([
  fetch("/api/schema").then((r) => r.json()),
  fetch("/api/presets").then((r) => r.json()),
]);

// ------------------------------------------------------------------ stream
// a viewer of a live session connects with its token alone (the look is the presenter's);
// a page of its own connects with its look and a room (live.js)
const stream = new Stream(canvas, () => (liveToken ? "" : location.search.slice(1)));
// a viewer gives its token's room too: a load balancer that hashes by `room` alone (the
// Kubernetes ingress, docker/k8s/ingress-ws.yaml) sends it where its presenter is
stream.extra = liveToken ? `live=${liveToken}&room=${liveToken.split(".")[0]}` : `room=${newRoom()}`;
const steers = () => canSteer(store.get().live);
window.fogbank = {
  stream, store,
  get params() { return store.get().params; },
  get version() { return version(store.get()); },
};

// Patches are merged and sent at most once per animation frame.
function merge(a, b) {
  if (a && b && typeof a === "object" && typeof b === "object" && !Array.isArray(a) && !Array.isArray(b)) {
    const out = { ...a };
    for (const [k, v] of Object.entries(b)) out[k] = k in a ? merge(a[k], v) : v;
    return out;
  }
  return b;
}
function queueFlush() {
  if (store.get().flushQueued) return;
  store.set({ flushQueued: true });
  requestAnimationFrame(() => {
    const { pendingParams, pendingCamera } = store.get();
    store.set({ flushQueued: false, pendingParams: null, pendingCamera: null });
    const unsent = {};
    if (pendingParams && !stream.send({ type: "params", params: pendingParams })) Object.assign(unsent, pendingParams);
    if (pendingCamera && !stream.send({ type: "camera", camera: pendingCamera })) {
      unsent.camera = merge(unsent.camera || {}, pendingCamera);
    }
    // disconnected: kept, and sent when the connection is back
    if (Object.keys(unsent).length) store.update((s) => ({ unsent: merge(s.unsent || {}, unsent) }));
  });
}

function setInteract(active) {
  if (active === store.get().interacting || (active && !steers())) return;
  store.set({ interacting: active });
  stream.send({ type: "interact", active });
}

// ------------------------------------------------------------------ camera bounds
// the scene's bounds for the eye (the schema's camera_bounds): drags, flights and typed
// positions stay within them
const cameraBounds = () => schema.camera_bounds[store.get().params?.scene || "countryside"];
function clampCamera(camera) {
  if (!camera.position) return camera;
  const b = cameraBounds();
  const p = camera.position.map((v, i) => Math.min(b.max[i], Math.max(b.min[i], v)));
  if (p.some((v, i) => v !== camera.position[i]) && !store.get().interacting) {
    toast(`The camera stays within the ${store.get().params.scene} scene: x ${b.min[0]} to ${b.max[0]}, ` +
      `y ${b.min[1]} to ${b.max[1]}, z ${b.min[2]} to ${b.max[2]} m`);
  }
  return { ...camera, position: p };
}

// ------------------------------------------------------------------ undo and redo
// Look changes (edits, presets, resets, layers added) are undoable; camera drags are not
// (the camera has its own reset). Edits of one field in quick succession are one step.
const looks = new UndoStack();
function remember(path, touchesCamera) {
  const s = store.get();
  if (s.params) looks.record(s.params, path.join("."), touchesCamera);
  showHistory();
}
function restore(entry) {
  if (!entry || !steers()) return;
  const s = store.get();
  // the animation keeps its time; the camera goes back only with a change that moved it
  const { time, ...look } = entry.params;
  const params = entry.camera ? look : { ...look, camera: s.params.camera };
  store.set({ params: { ...s.params, ...params }, redrawNext: true });
  stream.send({ type: "params", params });
  showHistory();
}
function showHistory() {
  $("undo").disabled = !looks.canUndo();
  $("redo").disabled = !looks.canRedo();
}
$("undo").addEventListener("click", () => restore(looks.undo(store.get().params)));
$("redo").addEventListener("click", () => restore(looks.redo(store.get().params)));
addEventListener("keydown", (e) => {
  if (!(e.ctrlKey || e.metaKey) || e.key.toLowerCase() !== "z") return;
  const t = e.target;
  // a text field being edited keeps its own undo
  if (t instanceof HTMLInputElement && (t.type === "text" || t.type === "number") && t.value !== t.defaultValue) return;
  e.preventDefault();
  restore(e.shiftKey ? looks.redo(store.get().params) : looks.undo(store.get().params));
});

// ------------------------------------------------------------------ controls
const controls = new Controls($("controls"), schema, (path, value) => {
  remember(path, path[0] === "camera");
  if (path.join(".") === "camera.position") value = clampCamera({ position: value }).position;
  // a list added to, removed from or reordered, or a layer toggled, changes the form
  const structural = (Array.isArray(value) && (value.length === 0 || typeof value[0] === "object"))
    || path.at(-1) === "enabled";
  let notes = [];
  store.update((s) => {
    let patch = buildPatch(s.params, path, value);
    // a field of a layer: its kind's cross-field rules are kept (controls.js keepRules), so
    // that the control never offers what the server then refuses
    if (path[0] === "layers" && path.length >= 3 && !structural) {
      const i = Number(path[1]);
      const edited = merge(s.params, patch).layers?.[i];
      const kept = edited && keepRules(edited, itemSchemaAt(schema, s.params, ["layers"], i), String(path[2]));
      if (kept && kept.notes.length) {
        notes = kept.notes;
        if (!kept.layer) return {};   // not made: the control shows the look's value again (ruleNote)
        patch = buildPatch(s.params, ["layers", i], kept.layer);
      }
    }
    return {
      params: merge(s.params, patch),
      pendingParams: merge(s.pendingParams || {}, patch),
      ...(structural ? { redrawNext: true } : {}),
    };
  });
  if (notes.length) ruleNote(path, notes);
  queueFlush();
}, addLayer);

// A rule's note, next to the control that was edited (in words; it goes with the next edit
// or after a while), and the control set to what the look now holds (a focused field keeps
// its text otherwise).
function ruleNote(path, notes) {
  const field = controls.form.querySelector(`[data-path="${CSS.escape(path.join("."))}"]`);
  const wrap = field?.closest(".field");
  if (!wrap) return;
  for (const old of controls.form.querySelectorAll(".rule-note")) old.remove();
  const held = valueAtPath(store.get().params, path);
  if (field && held !== undefined && typeof held !== "object" && field.value !== String(held)) {
    field.value = String(held);
    const range = wrap.querySelector('input[type="range"]');
    if (range?.toValueText) range.value = range.toValueText(String(held));
  }
  const note = document.createElement("p");
  note.className = "rule-note";
  note.setAttribute("role", "status");
  note.textContent = notes.map((n) => n.text).join(" ");
  wrap.after(note);
  clearTimeout(ruleNote.timer);
  ruleNote.timer = setTimeout(() => note.remove(), 10000);
}

function valueAtPath(obj, path) {
  return path.reduce((v, k) => (v == null ? v : v[k]), obj);
}
controls.onChange.interact = setInteract;
controls.ctx.cameraBounds = cameraBounds;
// the function editor of a polynomial or cosine layer: a shape that breaks no rule
// patches the layer as it is now
controls.ctx.functionEditor = (path, item) => functionEditor(item, (fitted) => {
  const current = path.reduce((v, k) => v[k], store.get().params);
  controls.onChange(path, { ...current, ...fitted });
});

// "Add layer": the server suggests one that suits the look (placed in front of the
// camera, thin enough never to white out the view); each click appends to the list as it
// is when its answer comes, and the new layer opens.
async function addLayer(path, kind) {
  let layer = { kind };
  try {
    const r = await fetch("/api/layers/suggest", {
      method: "POST", headers: { "content-type": "application/json" },
      body: JSON.stringify({ kind, params: store.get().params }),
    });
    if (r.ok) layer = await r.json();
  } catch { /* offline: the kind's defaults */ }
  const list = path.reduce((v, k) => v[k], store.get().params);
  controls.open([...path, list.length].join("."));
  controls.onChange(path, [...list, layer]);
}

// ------------------------------------------------------------------ camera
new CameraInput(canvas, () => store.get().params.camera, (patch) => {
  if (!steers()) return;   // watching a live session: the camera is the presenter's
  patch = clampCamera(patch);
  store.update((s) => ({
    params: { ...s.params, camera: { ...s.params.camera, ...patch } },
    pendingCamera: { ...(s.pendingCamera || {}), ...patch },
  }));
  queueFlush();
}, setInteract);

// ------------------------------------------------------------------ server messages
stream.addEventListener("hello", (e) => {
  $("stat-renderer").textContent = e.detail.renderer;
  const { refine_budget_ms: paused, play_budget_ms: playing } = e.detail;
  if (paused && playing) {   // the server's budgets, so that the page never quotes stale ones
    $("stat-reduced").title = `this look costs more a frame than the stream allows (${paused / 1000} s paused, ` +
      `${playing / 1000} s while time runs): the stream shows it reduced; Download gives the full quality`;
  }
});
stream.addEventListener("state", (e) => {
  const { type, answers, ...confirmed } = e.detail;
  store.update((s) => {
    // keep the camera being dragged, and edits not yet sent
    const shown = s.interacting && s.params ? { ...confirmed.params, camera: s.params.camera } : confirmed.params;
    return { confirmed, params: s.unsent ? merge(shown, s.unsent) : shown };
  });
  const s = store.get();
  if (s.redrawNext) {
    controls.render(s.params);
    store.set({ redrawNext: false });
  }
});
// A camera message's reply: the version and the camera alone (not the look), applied to
// the look last confirmed, its query spliced (links.js withCamera)
stream.addEventListener("camera", (e) => {
  const { version, camera, query } = e.detail;
  store.update((s) => {
    if (!s.confirmed) return {};
    const confirmed = { ...s.confirmed, version, query: withCamera(s.confirmed.query, query),
      params: { ...s.confirmed.params, camera } };
    return s.interacting ? { confirmed } : { confirmed, params: { ...s.params, camera } };
  });
});
// the panel shows the look on screen: every change of it (a drag, an edit, a confirmed
// state) sets the controls in place, and rebuilds the form when its shape changed
store.subscribe((s, prev) => {
  if (s.params && s.params !== prev.params && !s.redrawNext) controls.sync(s.params);
});
stream.addEventListener("error", (e) => {
  if (e.detail.kept) {   // a link with bad parts: the rest of its look is shown
    notice(`This link had parts that could not be used, so they were left out: ${e.detail.msg}. ` +
      "The rest of its look is shown.");
    return;
  }
  toast(e.detail.msg || "error");
  // a refused change of the look (its fields in `detail`): the server kept its last valid
  // look, show it again. A frame's failure, a deadline or a rate limit changes no look:
  // resending would only start the same costly frame again.
  if (Array.isArray(e.detail.detail)) {
    store.set({ redrawNext: true });
    stream.send({ type: "params", params: {} });
  }
});
stream.addEventListener("link", (e) => {
  const { type, ...link } = e.detail;
  store.set({ link });
});
stream.addEventListener("frame", (e) => {
  store.update((s) => ({ lastFrame: e.detail, frames: s.frames + 1 }));
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
stream.addEventListener("open", () => {
  banner(null);
  const { unsent } = store.get();
  store.set({ redrawNext: true, unsent: null });
  sendView();
  if (unsent) stream.send({ type: "params", params: unsent });   // the edits made while away
});

// ------------------------------------------------------------------ views of the state
store.subscribe((s, prev) => {
  if (s.confirmed !== prev.confirmed) showConfirmed(s.confirmed);
  if (s.lastFrame !== prev.lastFrame) showFrame(s);
});

// The preset a look started from: the one chosen, or for a link, the preset it matches
// or shares the most of its query with. "Reset to preset" and "Reset camera" go back to it.
function basePreset(query) {
  const keys = new Set(lookOf(query).split("&"));
  let best = presets[0], most = -1;
  for (const p of presets) {
    const shared = lookOf(p.query).split("&").filter((kv) => keys.has(kv)).length;
    if (shared > most) { best = p; most = shared; }
  }
  return best;
}
function showAbout(c) {
  const match = presets.find((p) => lookOf(p.query) === lookOf(c.query));
  if (match || !store.get().base) store.set({ base: (match || basePreset(c.query)).name });
  const base = presets.find((p) => p.name === store.get().base);
  $("about-title").textContent = match ? match.title : `Custom look, from “${base.title}”`;
  $("about-text").textContent = base.description;
  $("about-source").textContent = `Source: ${base.source}`;
}
$("reset-look").addEventListener("click", () => {
  const base = presets.find((p) => p.name === store.get().base);
  remember(["preset"], true);
  store.set({ redrawNext: true });
  stream.send({ type: "query", query: base.query });
});
$("reset-camera").addEventListener("click", () => {
  const base = presets.find((p) => p.name === store.get().base);
  remember(["camera"], true);
  const camera = structuredClone(base.params.camera);
  store.update((s) => ({ params: { ...s.params, camera } }));
  stream.send({ type: "camera", camera });
});

// the URL and the toolbar show the look the server last confirmed
function showConfirmed(c) {
  showAbout(c);
  writeAddress(c.query);
  $("play").textContent = c.playing ? "Pause" : "Play";
  $("play").setAttribute("aria-pressed", String(c.playing));
  $("speed").value = String(c.speed);
  // a preset paused, sped up or at another time is still that preset
  const match = presets.find((p) => lookOf(p.query) === lookOf(c.query));
  $("preset").value = match ? match.name : "";
}

// The address bar follows the confirmed look, with the framing when it is the link's;
// compact (links.js) when the readable query is long, so that it can be copied as it is.
async function writeAddress(query) {
  if (liveToken) return;   // a viewer's address stays the live link
  let q = query === "v=1" ? "" : query;
  const { framing } = store.get();
  if (framing) q += `${q ? "&" : ""}aspect=${Math.round(framing * 1000) / 1000}`;
  if (isLong(q)) q = await compactQuery(q);
  if (store.get().confirmed?.query !== query) return;   // a newer look came meanwhile
  if (location.search.slice(1) !== q) history.replaceState(null, "", q ? `?${q}` : location.pathname);
}
// the framing of the link the page was opened with
{
  const a = Number(new URLSearchParams(location.search).get("aspect"));
  if (a >= 0.25 && a <= 4) store.set({ framing: a });
}
function showFraming() {
  const { framing } = store.get();
  $("framing").hidden = !framing;
  if (framing) $("framing-text").textContent = `Framed as the link, ${framing.toFixed(2)}:1`;
}
$("fit-window").addEventListener("click", () => {
  store.set({ framing: null });
  const c = store.get().confirmed;
  if (c) writeAddress(c.query);
  sendView();
  showViewSize();
});
store.subscribe((s, prev) => { if (s.framing !== prev.framing) showFraming(); });
showFraming();

// a query without the keys that say where the animation is, not what it shows
function lookOf(query) {
  return query.split("&").filter((kv) => !/^(play|speed|time|aspect)=/.test(kv)).join("&");
}

// the time slider (unless it is being dragged) and the canvas's data-* follow the frames
function showFrame(s) {
  const f = s.lastFrame;
  if (!s.scrubbing) {
    const t = $("time");
    if (f.time > Number(t.max)) t.max = String(Math.ceil(f.time / 600) * 600);
    t.value = String(f.time);
  }
  $("time-out").textContent = `${f.time.toFixed(1)} s`;
  canvas.dataset.frame = String(f.frame);
  canvas.dataset.version = String(f.version);
  canvas.dataset.full = String(f.full);
  canvas.dataset.reduced = String(f.reduced);
  canvas.dataset.frames = String(s.frames);
}

// ------------------------------------------------------------------ toolbar
for (const p of presets) $("preset").append(new Option(p.title, p.name));
$("preset").append(new Option("(custom)", ""));
$("preset").addEventListener("change", () => {
  const p = presets.find((x) => x.name === $("preset").value);
  if (!p) return;
  remember(["preset"], true);
  store.set({ redrawNext: true, base: p.name });
  stream.send({ type: "query", query: p.query });
});
$("play").addEventListener("click", () => stream.send({ type: "play", playing: !playing(store.get()) }));
$("speed").addEventListener("change", () => stream.send({ type: "speed", speed: Number($("speed").value) }));
$("time").addEventListener("input", () => {
  store.set({ scrubbing: true });
  $("time-out").textContent = `${Number($("time").value).toFixed(1)} s`;
  stream.send({ type: "seek", time: Number($("time").value) });
});
$("time").addEventListener("change", () => { store.set({ scrubbing: false }); });
// The link to share: the look, at the time on screen now (while playing, the address
// bar's time is that of the last seek or pause); compact (links.js) when the readable one
// is long, readable otherwise (people read short ones).
async function shareLink() {
  // (a viewer of a live session: the look it watches, not the live link)
  const q = new URLSearchParams(liveToken ? store.get().confirmed?.query || "" : location.search);
  if (playing(store.get()) && store.get().lastFrame) q.set("time", String(Math.round(simTime(store.get()) * 1000) / 1000));
  q.set("aspect", String(Math.round(viewAspect() * 1000) / 1000));
  let text = q.toString().replace(/%2C/g, ",");
  if (isLong(text)) text = await compactQuery(text);
  return `${location.origin}${location.pathname}${text ? `?${text}` : ""}`;
}
$("copy-link").addEventListener("click", async () => {
  const link = await shareLink();
  try {
    await navigator.clipboard.writeText(link);
    toast("Link copied");
  } catch {
    prompt("Copy this link", link);
  }
});
// the still's size: the view's own shape by default (1920 px on its long side), or a preset size
function stillSize() {
  const v = $("still-size").value;
  if (v !== "view") return v.split("x").map(Number);
  const aspect = viewAspect();
  return aspect >= 1 ? [1920, Math.round(1920 / aspect / 2) * 2] : [Math.round(1920 * aspect / 2) * 2, 1920];
}
function showViewSize() {
  const opt = $("still-size").querySelector('option[value="view"]');
  const [w, h] = stillSize();
  opt.textContent = $("still-size").value === "view" ? `as the view, ${w}×${h}` : "as the view";
}
$("still-size").addEventListener("change", showViewSize);
$("download").addEventListener("click", async () => {
  const [w, h] = stillSize();
  // the confirmed look (readable), at the time on screen and the view's shape; compact
  // when long, with the size inside z (only play, speed, time, aspect stand beside it)
  const q = new URLSearchParams(store.get().confirmed.query);
  q.set("time", String(Math.round(simTime(store.get()) * 1000) / 1000));
  q.set("width", String(w));
  q.set("height", String(h));
  let text = q.toString();
  if (isLong(text)) text = await compactQuery(text);
  const a = document.createElement("a");
  a.href = `/api/still.png?${text}`;
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
addEventListener("resize", debounce(() => { sendView(); showViewSize(); }, 150));

// The stream's size. "auto": the canvas's own device pixels (its CSS size times
// devicePixelRatio, in the view's shape), scaled down to at most STREAM_PIXELS; or a
// chosen height. The cap is 1280x720's pixels: what the server streams smoothly (docs/bench.md).
const STREAM_PIXELS = 1280 * 720;
const even = (v) => Math.max(16, Math.round(v / 2) * 2);
// The view's shape: the framing of the link it was opened with (kept until "Fit to
// window"), else the stage's. What you see is what you share: the link and the
// download carry it.
function viewAspect() {
  const { framing } = store.get();
  if (framing) return framing;
  const stage = $("stage");
  return Math.max(0.5, Math.min(3, stage.clientWidth / Math.max(1, stage.clientHeight)));
}
function viewSize() {
  const stage = $("stage");
  const aspect = viewAspect();
  const choice = $("stream-size").value;
  if (choice === "auto") {
    const dpr = window.devicePixelRatio || 1;
    let w = stage.clientWidth * dpr, h = stage.clientHeight * dpr;
    if (w / h > aspect) w = h * aspect; else h = w / aspect;
    const scale = Math.min(1, Math.sqrt(STREAM_PIXELS / (w * h)), 1920 / w, 1080 / h);
    return [even(w * scale), even(h * scale)];
  }
  let height = Number(choice);
  let width = even(height * aspect);
  if (width > 1920) { width = 1920; height = even(1920 / aspect); }
  return [width, height];
}
function sendView() {
  const [width, height] = viewSize();
  const { show, showLayer } = store.get();
  stream.setView({ width, height, fps: 60, quality: 80, show, layer: showLayer });
}

// ------------------------------------------------------------------ views that teach
// The frames show the look, its transmittance, one layer's optical depth, or where the
// closed forms and a raymarch differ; the server sends each view's numbers and legend.
$("show").addEventListener("change", () => {
  store.set({ show: $("show").value, viewStats: null });
  sendView();
});
$("show-layer").addEventListener("change", () => {
  store.set({ showLayer: Number($("show-layer").value), viewStats: null });
  sendView();
});
stream.addEventListener("view_stats", (e) => store.set({ viewStats: e.detail }));
// the plot panel: each layer's density and T along the ray under the cursor
rayPlot(canvas, $("plot"), () => store.get().params, () => store.get().probe);
$("probe").addEventListener("change", () => store.set({ probe: $("probe").checked }));
store.subscribe((s, prev) => { if (s.probe !== prev.probe) $("plot").hidden = !s.probe; });
store.subscribe((s, prev) => {
  if (s.params && (s.params.layers !== prev.params?.layers || s.show !== prev.show)) showLayers(s);
  if (s.viewStats !== prev.viewStats || s.show !== prev.show) showLegend(s);
});
function showLayers(s) {
  const sel = $("show-layer");
  const layers = s.params.layers;
  sel.hidden = s.show !== "optical_depth";
  const names = layers.map((l, i) => `${i + 1}. ${l.kind}`);
  if ([...sel.options].map((o) => o.text).join() !== names.join()) {
    sel.replaceChildren(...names.map((n, i) => new Option(n, String(i))));
  }
  // the layer shown must exist: the last one when the list got shorter; with no layers
  // left there is no optical depth to show, and the look is shown
  if (!layers.length && s.show === "optical_depth") {
    $("show").value = "shaded";
    store.set({ show: "shaded", viewStats: null });
    sendView();
    return;
  }
  const layer = Math.min(s.showLayer, Math.max(0, layers.length - 1));
  sel.value = String(layer);
  if (layer !== s.showLayer) { store.set({ showLayer: layer }); sendView(); }
}
const fmt = (v) => (v === 0 ? "0" : Math.abs(v) >= 0.01 && Math.abs(v) < 1000 ? v.toPrecision(3) : v.toExponential(2));
function showLegend(s) {
  const st = s.viewStats;
  $("legend").hidden = s.show === "shaded" || !st;
  if (!st || s.show === "shaded") return;
  $("legend-label").textContent = st.legend.label;
  $("legend-lo").textContent = fmt(st.legend.lo);
  $("legend-hi").textContent = (st.show === "transmittance" ? "" : "≥ ") + fmt(st.legend.hi);
  $("legend-bar").style.background = `linear-gradient(to right, ${st.legend.colors.join(", ")})`;
  const lines = {
    transmittance: () => `min T ${fmt(st.min)} · mean T ${fmt(st.mean)}`,
    optical_depth: () => `layer ${st.layer + 1} (${st.kind}) · max τ ${fmt(st.max)} · mean τ ${fmt(st.mean)}`,
    difference: () => `max |ΔT| ${fmt(st.max_abs_dT)} · 99% of pixels under ${fmt(st.p99_abs_dT)} · ` +
      "where they differ, the raymarch errs",
  };
  $("legend-stats").textContent = lines[st.show]?.() || "";
}

// ------------------------------------------------------------------ overlay
// the link the page was opened with, before the address bar follows the look
const givenLink = location.href;
function notice(text) {
  $("notice-text").textContent = text;
  $("notice").hidden = false;
}
$("notice-close").addEventListener("click", () => { $("notice").hidden = true; });
$("copy-original").addEventListener("click", async () => {
  try {
    await navigator.clipboard.writeText(givenLink);
    toast("The link as given was copied");
  } catch {
    prompt("The link as given", givenLink);
  }
});
function banner(text) {
  const b = $("banner");
  b.hidden = !text;
  b.textContent = text || "";
}
const hideToast = debounce(() => { $("toast").hidden = true; }, 4000);
function toast(text) {
  const t = $("toast");
  t.textContent = text;
  t.hidden = false;
  hideToast();
}
// fn, called `ms` after the last of a burst of calls
function debounce(fn, ms) {
  let timer = 0;
  return () => { clearTimeout(timer); timer = setTimeout(fn, ms); };
}
// "VP9 · 0.8 of 4.8 Mbit/s · 41 ms", "JPEG q62 · ...": the last frame's codec (and quality), and the
// stream's rate against the link's, with its round trip, as the server measures them
function linkText(frame, link) {
  const mbps = (bps) => (bps / 1e6).toFixed(bps < 1e7 ? 1 : 0);
  const codec = frame.codec === "jpeg" ? `JPEG q${frame.quality}` : frame.codec === "vp09" ? "VP9" : "VP8";
  if (!link) return codec;
  // the rate reads the link only while the link limits the stream; else, at least that
  const rate = link.limiting ? `of ${mbps(link.rate_bps)}` : `(link ≥ ${mbps(link.rate_bps)})`;
  return `${codec} · ${mbps(link.stream_bps)} ${rate} Mbit/s · ${Math.round(link.rtt_ms)} ms`;
}
// the overlay: labelled, and blank while disconnected (no stale numbers)
setInterval(() => {
  const live = stream.connected;
  $("stat-fps").textContent = live ? `${stream.fps().toFixed(1)} fps` : "–";
  $("stat-latency").textContent = live && stream.latency != null ? `${Math.round(stream.latency)} ms` : "–";
  // (a video frame is often under a kilobyte: one decimal below 10 KB)
  const kb = live && stream.lastFrame ? stream.lastFrame.bytes / 1024 : null;
  $("stat-size").textContent = kb === null ? "–" : `${kb.toFixed(kb < 10 ? 1 : 0)} KB`;
  $("stat-link").textContent = live && stream.lastFrame ? linkText(stream.lastFrame, store.get().link) : "–";
  $("stat-refining").hidden = !(live && stream.lastFrame && !stream.lastFrame.full);
  $("stat-reduced").hidden = !(live && stream.lastFrame && stream.lastFrame.full && stream.lastFrame.reduced);
}, 250);

// ------------------------------------------------------------------ live sessions
liveUi({ stream, store, $, toast, lookQuery: () => store.get().confirmed?.query || "" });

if (innerWidth < 900) {   // phones and narrow windows start with the view, not the panel
  document.body.classList.add("panel-hidden");
  $("toggle-panel").setAttribute("aria-expanded", "false");
}
sendView();
showViewSize();
stream.connect();
// video frames where WebCodecs decodes them (stream.js): asked for with the view
decodableCodecs().then((codecs) => stream.setCodecs(codecs));
