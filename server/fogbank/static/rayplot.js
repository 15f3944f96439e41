// The plot panel: the ray under the cursor (POST /api/plot/ray, float64 on the server):
// each layer's density along it, and the whole fog's T(s) from the eye. The pointer's
// position is mapped to the stream's pixels through the canvas's letterbox (object-fit:
// contain). One request at a time; the latest position wins.

import { COLORS, linePlot, svgEl } from "./plot.js";

// client coordinates -> the frame's pixel (x from the left, y from the top), or null
export function framePixel(canvas, clientX, clientY) {
  const box = canvas.getBoundingClientRect();
  const scale = Math.min(box.width / canvas.width, box.height / canvas.height);
  const w = canvas.width * scale, h = canvas.height * scale;
  const x = (clientX - box.left - (box.width - w) / 2) / scale;
  const y = (clientY - box.top - (box.height - h) / 2) / scale;
  if (!(x >= 0 && y >= 0 && x < canvas.width && y < canvas.height)) return null;
  return { x, y, width: canvas.width, height: canvas.height };
}

export function rayPlot(canvas, panel, getParams, isOn) {
  const svg = svgEl("svg", { viewBox: "0 0 320 250", width: "100%", role: "img",
    "aria-label": "density of each layer and T along the ray under the cursor" });
  const info = document.createElement("div");
  info.className = "info";
  const keys = document.createElement("div");
  keys.className = "keys";
  panel.append(info, svg, keys);
  let busy = false;
  let next = null;

  const draw = (data) => {
    svg.replaceChildren();
    const series = data.layers.filter((l) => l.density).map((l) => ({
      x: data.s, y: l.density, color: COLORS[l.index % COLORS.length], name: `${l.index + 1}. ${l.kind}`,
      dash: l.enabled ? null : "3 3" }));
    const x = [0, data.distance];
    linePlot(svg, { series, xRange: x, xLabel: "s, m from the eye", yLabel: "density, 1/m", height: 125 });
    const ts = [{ x: data.s, y: data.T, color: "#ffffff", name: "T(s)" }].concat(
      data.layers.filter((l) => l.transmittance).map((l) => ({ x: data.s, y: l.transmittance,
        color: COLORS[l.index % COLORS.length], name: `${l.index + 1}. ${l.kind} (its T)`, dash: "4 2" })));
    linePlot(svg, { series: ts, xRange: x, yRange: [0, 1], xLabel: "s, m", yLabel: "T(s)", top: 125, height: 125 });
    keys.replaceChildren(...series.concat(ts).map((s) => {
      const k = document.createElement("span");
      k.style.setProperty("--c", s.color);
      k.textContent = s.name;
      return k;
    }));
    info.textContent = `${data.hit === "ground" ? "ground" : "sky"} at ${data.distance.toFixed(1)} m · T = ${data.T.at(-1).toPrecision(3)}`;
    panel.dataset.x = String(data.pixel.x);
    panel.dataset.y = String(data.pixel.y);
  };

  const ask = async () => {
    if (busy || !next) return;
    busy = true;
    const pixel = next;
    next = null;
    try {
      const r = await fetch("/api/plot/ray", {
        method: "POST", headers: { "content-type": "application/json" },
        body: JSON.stringify({ params: getParams(), ...pixel }),
      });
      const data = await r.json();
      if (r.ok) draw({ ...data, pixel });
      else info.textContent = data.detail?.[0]?.msg || r.statusText;
    } catch (err) {
      info.textContent = String(err.message || err);
    } finally {
      busy = false;
      ask();
    }
  };

  canvas.addEventListener("pointermove", (e) => {
    if (!isOn() || e.buttons) return;   // a drag moves the camera
    const p = framePixel(canvas, e.clientX, e.clientY);
    if (!p) return;
    next = p;
    ask();
  });
}
