// Line plots in plain SVG (no library): the ray plot panel and the function editor draw
// with these. A plot maps data to its box and back (for dragging points).

const NS = "http://www.w3.org/2000/svg";

export function svgEl(tag, attrs = {}, text = null) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (text != null) e.textContent = text;
  return e;
}

const fmt = (v) => (v === 0 ? "0" : Math.abs(v) >= 0.01 && Math.abs(v) < 10000 ? String(Number(v.toPrecision(3))) : v.toExponential(1));

// A plot in `svg` (its viewBox sets the size): series [{x: [], y: [], color, name,
// dash}], x and y ranges [lo, hi] (y defaults to the data's), axis labels. Returns
// {toX, toY, fromY, g}: data -> box coordinates, box y -> data, and the plot's group.
export function linePlot(svg, { series, xRange, yRange, xLabel = "", yLabel = "", top = 0, height = null }) {
  const [W, H] = svg.getAttribute("viewBox").split(" ").slice(2).map(Number);
  const h = height ?? H;
  const m = { l: 44, r: 8, t: 8, b: 26 };
  const ys = series.flatMap((s) => s.y.filter(Number.isFinite));
  let [y0, y1] = yRange ?? [Math.min(0, ...ys), Math.max(...ys, 1e-12)];
  if (y1 <= y0) y1 = y0 + 1;
  const [x0, x1] = xRange;
  const toX = (x) => m.l + ((x - x0) / (x1 - x0)) * (W - m.l - m.r);
  const toY = (y) => top + m.t + (1 - (y - y0) / (y1 - y0)) * (h - m.t - m.b);
  const fromY = (py) => y0 + (1 - (py - top - m.t) / (h - m.t - m.b)) * (y1 - y0);
  const g = svgEl("g", { class: "plot" });
  g.append(svgEl("rect", { x: m.l, y: top + m.t, width: W - m.l - m.r, height: h - m.t - m.b, class: "frame" }));
  for (const v of [y0, (y0 + y1) / 2, y1]) {
    g.append(svgEl("text", { x: m.l - 4, y: toY(v) + 4, "text-anchor": "end", class: "tick" }, fmt(v)));
  }
  for (const v of [x0, (x0 + x1) / 2, x1]) {
    g.append(svgEl("text", { x: toX(v), y: top + h - m.b + 13, "text-anchor": "middle", class: "tick" }, fmt(v)));
  }
  if (xLabel) g.append(svgEl("text", { x: W - m.r, y: top + h - 2, "text-anchor": "end", class: "label" }, xLabel));
  if (yLabel) g.append(svgEl("text", { x: m.l + 4, y: top + m.t + 11, class: "label" }, yLabel));
  for (const s of series) {
    const d = s.x.map((x, i) => (Number.isFinite(s.y[i]) ? `${i ? "L" : "M"}${toX(x).toFixed(1)},${toY(Math.max(y0, Math.min(y1, s.y[i]))).toFixed(1)}` : "")).join("");
    g.append(svgEl("path", { d, stroke: s.color, fill: "none", "stroke-width": 1.6,
      ...(s.dash ? { "stroke-dasharray": s.dash } : {}), "data-name": s.name || "" }));
  }
  svg.append(g);
  return { toX, toY, fromY, g };
}

// distinct colours for layers (Okabe-Ito, readable by colour-blind viewers)
export const COLORS = ["#e69f00", "#56b4e9", "#009e73", "#f0e442", "#0072b2", "#d55e00", "#cc79a7", "#ffffff"];
