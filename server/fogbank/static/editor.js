// The function editor (Biri 2002, Fig. 2): a polynomial or cosine layer's shape along its
// axis, drawn from POST /api/layers/profile (float64, on the server). Dragging a point
// asks the server for the coefficients through the points and the rules the shape would
// break; a shape that breaks none is sent to the look when the drag ends, one that
// breaks a rule is shown with the rule and where, and not sent. The draft being dragged
// is this widget's own, as a number field's text is until it is committed.

import { linePlot, svgEl } from "./plot.js";

async function fetchProfile(layer, points = null) {
  const r = await fetch("/api/layers/profile", {
    method: "POST", headers: { "content-type": "application/json" },
    body: JSON.stringify({ layer, points }),
  });
  const body = await r.json();
  if (!r.ok) throw new Error(body.detail?.[0]?.msg || r.statusText);
  return body;
}

// An editor for `layer` (the list item at `path`); apply(fitted) patches the layer with
// the fitted coefficients ({coeffs} or {c0, terms}).
export function functionEditor(layer, apply) {
  const box = document.createElement("div");
  box.className = "function-editor";
  const svg = svgEl("svg", { viewBox: "0 0 300 170", width: "100%", role: "img",
    "aria-label": `the ${layer.kind} layer's shape along its axis; drag the points to reshape it` });
  const note = document.createElement("p");
  note.className = "problems";
  note.setAttribute("role", "status");
  box.append(svg, note);
  let prof = null;
  let pending = null;      // the points of the drag in progress (the latest request wins)
  let asked = 0;

  // While a point is dragged, the y range stays as it was when the drag began, and the
  // dragged circle is kept (moved, not made anew); everything else is redrawn.
  let drag = null;   // {i, el, range}
  const draw = () => {
    svg.replaceChildren();
    const ys = prof.shape.concat(prof.points.map((p) => p[1]));
    const lo = Math.min(0, ...ys), hi = Math.max(...ys, 1e-9);
    const pad = (hi - lo) * 0.15;
    const range = drag ? drag.range : [lo - pad, hi + pad];
    const p = linePlot(svg, {
      series: [{ x: prof.u, y: prof.shape, color: "#9fd0ff", name: "shape" }],
      xRange: [prof.u[0], prof.u.at(-1)], yRange: range,
      xLabel: prof.axis_label, yLabel: prof.kind === "polynomial" ? "P(u)" : "c₀ + Σ cᵢ cos(…)",
    });
    const clampY = (v) => p.toY(Math.max(range[0], Math.min(range[1], v)));
    // the tile (polynomial) or one period (cosine), and zero
    for (const t of prof.tile) {
      p.g.append(svgEl("line", { x1: p.toX(t), x2: p.toX(t), y1: p.toY(range[0]), y2: p.toY(range[1]), class: "tile" }));
    }
    p.g.append(svgEl("line", { x1: p.toX(prof.u[0]), x2: p.toX(prof.u.at(-1)), y1: clampY(0), y2: clampY(0), class: "zero" }));
    for (const bad of prof.problems) {
      p.g.append(svgEl("circle", { cx: p.toX(bad.at), cy: clampY(bad.rule === "negative" ? bad.value : 0),
        r: 6, class: "broken", "data-rule": bad.rule }));
    }
    prof.points.forEach(([u, v], i) => {
      const label = `point ${i + 1}: ${v.toPrecision(3)}`;
      if (drag && drag.i === i) {   // the dragged one: moved, not replaced
        drag.el.setAttribute("cy", String(clampY(v)));
        drag.el.setAttribute("aria-label", label);
        p.g.append(drag.el);
        return;
      }
      const c = svgEl("circle", { cx: p.toX(u), cy: clampY(v), r: 5, class: "point", tabindex: 0,
        "data-index": i, "aria-label": label });
      c.addEventListener("pointerdown", (e) => {
        e.preventDefault();
        // the window follows the drag: redrawing takes the circle out of the document for
        // a moment, which would end a pointer capture
        drag = { i, el: c, range };
        const values = prof.points.map((q) => q[1]);
        const toValue = p.fromY;
        const move = (ev) => {
          const r = svg.getBoundingClientRect();
          values[i] = Number(toValue(((ev.clientY - r.top) / r.height) * 170).toPrecision(4));
          c.setAttribute("cy", String(clampY(values[i])));
          reshape(values.slice());
        };
        const up = () => {
          removeEventListener("pointermove", move);
          removeEventListener("pointerup", up);
          removeEventListener("pointercancel", up);
          settle();
        };
        addEventListener("pointermove", move);
        addEventListener("pointerup", up);
        addEventListener("pointercancel", up);
      });
      p.g.append(c);
    });
    note.textContent = prof.problems.map((b) => b.msg).join(" ");
    box.classList.toggle("broken", prof.problems.length > 0);
  };

  const reshape = async (values) => {
    pending = values;
    const n = ++asked;
    try {
      const next = await fetchProfile(layer, values);
      if (n === asked) { prof = next; draw(); }
    } catch (err) {
      note.textContent = String(err.message || err);
    }
  };
  // the drag ended: a shape that breaks no rule goes to the look
  const settle = async () => {
    const values = pending;
    pending = null;
    drag = null;
    if (!values) { draw(); return; }
    const n = ++asked;
    let next;
    try {
      next = await fetchProfile(layer, values);
    } catch (err) {
      note.textContent = String(err.message || err);
      return;
    }
    if (n !== asked) return;
    prof = next;
    draw();
    if (!prof.problems.length) {
      layer = { ...layer, ...prof.fitted };   // the look now has these coefficients
      apply(prof.fitted);
    }
  };

  // The look's layer changed from elsewhere (a typed coefficient, the tile's width, an
  // undo): the editor shows that layer, not the one it was opened with.
  box.refresh = (next) => {
    if (drag || JSON.stringify(next) === JSON.stringify(layer)) return;
    layer = next;
    const n = ++asked;
    fetchProfile(layer).then((p) => { if (n === asked) { prof = p; draw(); } })
      .catch((err) => { note.textContent = String(err.message || err); });
  };
  fetchProfile(layer).then((p) => { prof = p; draw(); }).catch((err) => { note.textContent = String(err.message || err); });
  return box;
}
