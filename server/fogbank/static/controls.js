// Controls built from the params' JSON Schema (/api/schema): a slider plus a typed number
// with its unit for every bounded number, checkboxes, selects for enums, colour pickers,
// vector fields, and list editors for layers and cosine terms. Every change calls
// onChange(path, value); the form follows the page's state: rebuilt when its shape
// changes, its controls set in place otherwise (Controls.sync).

const SKIP = new Set(["width", "height", "time"]);   // stills only, or on the toolbar
let uid = 0;

function resolve(schema, node) {
  while (node && node.$ref) node = schema.$defs[node.$ref.split("/").pop()];
  if (node && node.anyOf && !node.discriminator) {
    const real = node.anyOf.find((n) => n.type !== "null");
    return resolve(schema, real);
  }
  return node;
}

// a field's label: its title (words, or the pydantic title of its name), sentence case
function label(name, node) {
  const t = String((node && node.title) || name).replace(/_/g, " ");
  return t.charAt(0).toUpperCase() + t.slice(1);
}

function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") e.className = v;
    else if (k in e && typeof v !== "string") e[k] = v;
    else e.setAttribute(k, v);
  }
  for (const c of children) if (c != null) e.append(c);
  return e;
}

// The slider's scale, as the schema states it: "log" sliders map their 0..LOG_STEPS
// positions onto lo + knee ((span/knee + 1)^t - 1), t = position / LOG_STEPS, with the
// field's step as the knee: as fine as one step near the bottom, a constant ratio above.
const LOG_STEPS = 1000;
export function sliderScale(node, lo, hi) {
  const step = Number(node.step) || (hi - lo) / 1000;
  if (node.scale !== "log") {
    return { min: lo, max: hi, toValue: (p) => p, toPos: (v) => v };
  }
  const k = Math.log((hi - lo) / step + 1);
  return {
    min: 0, max: LOG_STEPS,
    toValue: (p) => lo + step * Math.expm1((p / LOG_STEPS) * k),
    toPos: (v) => (Math.log1p(Math.max(0, v - lo) / step) / k) * LOG_STEPS,
  };
}

// A slider's value as the field takes it: integers whole, log values to three
// significant figures, linear ones to the step; inside the bounds (an exclusive bound
// by a hair).
function tidy(v, node, lo, hi, integer) {
  const step = Number(node.step) || 0;
  if (integer) v = Math.round(v);
  else if (node.scale === "log") v = Number(v.toPrecision(3));
  else if (step) v = Number((Math.round((v - lo) / step) * step + lo).toFixed(12));
  v = Math.min(hi, Math.max(lo, v));
  if (node.exclusiveMinimum !== undefined && v <= node.exclusiveMinimum) {
    v = Number((node.exclusiveMinimum + (step || Math.abs(node.exclusiveMinimum) * 1e-3 || 1e-6)).toPrecision(6));
  }
  return v;
}

// The help line under a field: its meaning, unit and range (shown on hover and focus).
function helpText(node, lo, hi) {
  const parts = [];
  if (node.description) parts.push(node.description);
  if (node.unit) parts.push(`unit: ${node.unit}`);
  if (lo !== undefined && hi !== undefined) {
    parts.push(`${node.exclusiveMinimum !== undefined ? "above" : "from"} ${lo} to ${hi}` +
      (node.scale === "log" ? " (log slider)" : ""));
  }
  if (node.default !== undefined) parts.push(`default ${Array.isArray(node.default) ? node.default.join(", ") : node.default}; double-click to reset`);
  return parts.join(" · ");
}

function withHelp(wrap, node, lo, hi) {
  const text = helpText(node, lo, hi);
  if (text) wrap.append(el("small", { class: "help" }, text));
  return wrap;
}

// double-clicking a field's label (or slider) sets it back to its default
function resettable(target, path, node, onChange) {
  if (node.default === undefined) return;
  target.addEventListener("dblclick", (e) => {
    e.preventDefault();
    onChange(path, structuredClone(node.default));
  });
}

function numberControl(path, node, value, onChange, integer) {
  const id = `c${uid++}`;
  const min = node.minimum ?? node.exclusiveMinimum;
  const max = node.maximum ?? node.exclusiveMaximum;
  const step = node.step ?? (integer ? 1 : "any");
  const wrap = el("div", { class: "field number" });
  const lab = el("label", { for: id }, label(path.at(-1), node));
  if (node.description) lab.title = node.description;
  const num = el("input", { id, type: "number", value: String(value), step: String(step),
    "aria-describedby": `${id}-unit`, "data-path": path.join(".") });
  if (min !== undefined) num.min = String(min);
  if (max !== undefined) num.max = String(max);
  const unit = el("span", { class: "unit", id: `${id}-unit` }, node.unit || "");
  wrap.append(lab);
  resettable(lab, path, node, onChange);
  if (min !== undefined && max !== undefined && isFinite(min) && isFinite(max) && max - min <= 1e7) {
    const sc = sliderScale(node, min, max);
    const range = el("input", { type: "range", min: String(sc.min), max: String(sc.max), step: "any",
      value: String(sc.toPos(value)), "aria-label": `${label(path.at(-1), node)} slider`, tabindex: "-1",
      "data-scale": node.scale || "linear" });
    range.style.touchAction = "none";
    // The page drives the slider itself: a press jumps to the pointer, a drag moves by
    // the pointer's travel, and with Shift held by a tenth of it (fine drag).
    range.addEventListener("pointerdown", (e) => {
      if (e.button !== 0) return;
      e.preventDefault();
      range.setPointerCapture(e.pointerId);
      const rect = range.getBoundingClientRect();
      const span = sc.max - sc.min;
      let pos = Number(range.value);
      if (!e.shiftKey) pos = sc.min + span * Math.min(1, Math.max(0, (e.clientX - rect.left) / rect.width));
      let lastX = e.clientX;
      const apply = () => {
        const v = tidy(sc.toValue(pos), node, min, max, integer);
        range.value = String(pos);
        if (num.value !== String(v)) { num.value = String(v); onChange(path, v); }
      };
      const move = (ev) => {
        pos = Math.min(sc.max, Math.max(sc.min, pos + (ev.shiftKey ? 0.1 : 1) * (ev.clientX - lastX) / rect.width * span));
        lastX = ev.clientX;
        apply();
      };
      const up = () => {
        range.removeEventListener("pointermove", move);
        range.removeEventListener("pointerup", up);
        range.removeEventListener("pointercancel", up);
        onChange.interact?.(false);
      };
      range.addEventListener("pointermove", move);
      range.addEventListener("pointerup", up);
      range.addEventListener("pointercancel", up);
      onChange.interact?.(true);
      apply();
    });
    range.toValueText = (v) => String(sc.toPos(Number(v)));
    resettable(range, path, node, onChange);
    wrap.append(range);
  }
  num.addEventListener("change", () => {
    if (num.value === "" || !isFinite(Number(num.value))) return;
    const range = wrap.querySelector('input[type="range"]');
    if (range) range.value = range.toValueText(num.value);
    onChange(path, integer ? Math.round(Number(num.value)) : Number(num.value));
  });
  wrap.append(num, unit);
  return withHelp(wrap, node, min, max);
}

function vectorControl(path, node, value, onChange, ctx) {
  const legend = el("legend", {}, label(path.at(-1), node));
  const wrap = el("fieldset", { class: "field vector" }, legend);
  if (node.description) wrap.title = node.description;
  resettable(legend, path, node, onChange);
  // the camera's position: each axis within the scene's bounds (the schema's camera_bounds)
  const bounds = path.join(".") === "camera.position" ? ctx.cameraBounds?.() : null;
  const inputs = value.map((v, i) => {
    const inp = el("input", { type: "number", step: "any", value: String(v),
      "aria-label": `${label(path.at(-1), node)} ${"xyzw"[i] ?? i}`, "data-path": `${path.join(".")}.${i}` });
    if (bounds) { inp.min = String(bounds.min[i]); inp.max = String(bounds.max[i]); }
    inp.addEventListener("change", () => {
      const vals = inputs.map((x) => Number(x.value));
      if (vals.every(isFinite)) onChange(path, vals);
    });
    return inp;
  });
  wrap.append(...inputs);
  const help = bounds ? { ...node, description: `${node.description || ""}; in this scene x ${bounds.min[0]} to ${bounds.max[0]}, ` +
    `y ${bounds.min[1]} to ${bounds.max[1]}, z ${bounds.min[2]} to ${bounds.max[2]} m` } : node;
  return withHelp(wrap, help);
}

function listOfNumbersControl(path, node, value, onChange) {
  const id = `c${uid++}`;
  const inp = el("input", { id, type: "text", value: value.join(", "), "data-path": path.join("."),
    inputmode: "decimal" });
  inp.addEventListener("change", () => {
    const vals = inp.value.split(/[,\s]+/).filter(Boolean).map(Number);
    if (vals.length && vals.every(isFinite)) onChange(path, vals);
  });
  const lab = el("label", { for: id, title: node.description || "" }, label(path.at(-1), node));
  resettable(lab, path, node, onChange);
  return withHelp(el("div", { class: "field text" }, lab, inp), node);
}

function selectControl(path, node, options, value, onChange) {
  const id = `c${uid++}`;
  const sel = el("select", { id, "data-path": path.join(".") });
  for (const o of options) sel.append(el("option", { value: String(o), selected: o === value }, String(o)));
  sel.addEventListener("change", () => {
    const raw = sel.value;
    onChange(path, typeof value === "number" ? Number(raw) : raw);
  });
  const lab = el("label", { for: id, title: node.description || "" }, label(path.at(-1), node));
  resettable(lab, path, node, onChange);
  return withHelp(el("div", { class: "field select" }, lab, sel), node);
}

function field(schema, path, node, value, onChange, ctx) {
  // the property's own title (or name) beats the title of the class it refers to
  const title = (node && node.title) || (node && node.$ref ? path.at(-1).replace(/_/g, " ") : undefined);
  node = resolve(schema, node) || {};
  if (title && !node.$ref) node = { ...node, title };
  if (node.const !== undefined || path.at(-1) === "kind") return null;
  if (node.enum) return selectControl(path, node, node.enum, value, onChange);
  if (node.type === "boolean") {
    const id = `c${uid++}`;
    const cb = el("input", { id, type: "checkbox", checked: !!value, "data-path": path.join(".") });
    cb.addEventListener("change", () => onChange(path, cb.checked));
    return withHelp(el("div", { class: "field check" }, cb, el("label", { for: id, title: node.description || "" },
      label(path.at(-1), node))), node);
  }
  if (node.type === "number" || node.type === "integer") {
    return numberControl(path, node, value, onChange, node.type === "integer");
  }
  if (node.type === "string" && node.format === "color") {
    const id = `c${uid++}`;
    const inp = el("input", { id, type: "color", value, "data-path": path.join(".") });
    inp.addEventListener("input", () => onChange(path, inp.value));
    const lab = el("label", { for: id, title: node.description || "" }, label(path.at(-1), node));
    resettable(lab, path, node, onChange);
    return withHelp(el("div", { class: "field color" }, lab, inp), node);
  }
  if (node.type === "array" && node.prefixItems) return vectorControl(path, node, value, onChange, ctx);
  if (node.type === "array") {
    const items = node.items || {};
    if (items.type === "number") return listOfNumbersControl(path, node, value, onChange);
    return listControl(schema, path, node, value, onChange, ctx);
  }
  if (node.type === "object" || node.properties) {
    return group(schema, path, node, value, onChange, ctx);
  }
  return null;
}

function group(schema, path, node, value, onChange, ctx, open = false) {
  const box = el("details", { class: "group", open: open || ctx.openGroups.has(path.join(".")) });
  box.addEventListener("toggle", () => {
    if (box.open) ctx.openGroups.add(path.join(".")); else ctx.openGroups.delete(path.join("."));
  });
  box.append(el("summary", {}, label(path.at(-1), node)));
  for (const [name, sub] of Object.entries(node.properties || {})) {
    if (path.length === 0 && SKIP.has(name)) continue;
    const f = field(schema, [...path, name], sub, value[name], onChange, ctx);
    if (f) box.append(f);
  }
  return box;
}

function itemSchema(schema, node, item) {
  const items = node.items;
  if (items.discriminator) {
    return resolve(schema, { $ref: items.discriminator.mapping[item[items.discriminator.propertyName]] });
  }
  return resolve(schema, items);
}

function listControl(schema, path, node, value, onChange, ctx) {
  const box = el("fieldset", { class: "list" }, el("legend", {}, label(path.at(-1), node)));
  const set = (next) => onChange(path, next);
  value.forEach((item, i) => {
    const sub = itemSchema(schema, node, item);
    const name = item.kind ? `${i + 1}. ${sub.title || item.kind}` : `${label(path.at(-1), node).replace(/s$/, "")} ${i + 1}`;
    const gpath = [...path, i];
    const det = el("details", { class: "item", open: ctx.openGroups.has(gpath.join(".")) });
    det.addEventListener("toggle", () => {
      if (det.open) ctx.openGroups.add(gpath.join(".")); else ctx.openGroups.delete(gpath.join("."));
    });
    const tools = el("span", { class: "tools" });
    const btn = (text, title, fn, disabled = false) => {
      const b = el("button", { type: "button", title, "aria-label": `${title} ${name}`, disabled }, text);
      b.addEventListener("click", (e) => { e.preventDefault(); fn(); });
      return b;
    };
    if ("enabled" in item) {
      const cb = el("input", { type: "checkbox", checked: item.enabled, "aria-label": `Show ${name}` });
      cb.addEventListener("click", (e) => e.stopPropagation());
      cb.addEventListener("change", () => onChange([...gpath, "enabled"], cb.checked));
      tools.append(cb);
    }
    tools.append(
      btn("↑", "Move up", () => set(swap(value, i, i - 1)), i === 0),
      btn("↓", "Move down", () => set(swap(value, i, i + 1)), i === value.length - 1),
      btn("✕", "Remove", () => set(value.filter((_, j) => j !== i))));
    det.append(el("summary", {}, el("span", { class: "name" }, name), tools));
    if (sub.source) det.append(kindHelp(sub));
    // Biri's Fig. 2: the function editor for the kinds whose shape is a function
    if (ctx.functionEditor && (item.kind === "polynomial" || item.kind === "cosine")) {
      const shape = el("details", { class: "shape" }, el("summary", {}, "Shape the function (drag its points)"));
      shape.addEventListener("toggle", () => {
        if (shape.open && !shape.querySelector(".function-editor")) {
          const ed = ctx.functionEditor(gpath, item);
          ed.dataset.path = gpath.join(".");
          shape.append(ed);
        }
      }, { once: false });
      det.append(shape);
    }
    for (const [fname, fnode] of Object.entries(sub.properties || {})) {
      if (fname === "enabled") continue;
      const f = field(schema, [...gpath, fname], fnode, item[fname], onChange, ctx);
      if (f) det.append(f);
    }
    box.append(det);
  });
  const max = node.maxItems ?? Infinity;
  const add = el("div", { class: "add" });
  if (node.items.discriminator) {
    const id = `c${uid++}`;
    // the kinds in the registry's order (the union's), not the mapping's alphabetical one
    const order = (node.items.oneOf || []).map((o) => o.$ref);
    const mapping = node.items.discriminator.mapping;
    const kinds = Object.keys(mapping).sort((a, b) => order.indexOf(mapping[a]) - order.indexOf(mapping[b]));
    const sel = el("select", { id });
    for (const k of kinds) {
      const ks = resolve(schema, { $ref: node.items.discriminator.mapping[k] });
      sel.append(el("option", { value: k, title: ks.summary || "" }, ks.title || k));
    }
    if (ctx.addKind) sel.value = ctx.addKind;   // the kind last chosen survives a redraw
    sel.addEventListener("change", () => { ctx.addKind = sel.value; });
    const b = el("button", { type: "button", disabled: value.length >= max }, "Add layer");
    b.addEventListener("click", (e) => {
      e.preventDefault();
      // the page adds it to the list as it is then (every click counts), opened
      if (ctx.addLayer) ctx.addLayer(path, sel.value);
      else set([...value, { kind: sel.value }]);
    });
    add.append(el("label", { for: id }, "Kind"), sel, b);
  } else {
    const b = el("button", { type: "button", disabled: value.length >= max }, `Add ${label(path.at(-1), node).replace(/s$/, "")}`);
    const defaults = Object.fromEntries(Object.entries(itemSchema(schema, node, {}).properties || {})
      .map(([k, v]) => [k, v.default]));
    b.addEventListener("click", (e) => { e.preventDefault(); set([...value, defaults]); });
    add.append(b);
  }
  box.append(add);
  return box;
}

// What a layer kind is: a sentence, its formula (MathML from the schema, drawn by the
// browser) and its source.
export function kindHelp(sub) {
  const box = el("div", { class: "kind-help" }, el("p", { class: "summary" }, sub.summary));
  const formula = el("div", { class: "formula", "aria-label": `formula: ${sub.formula}` });
  formula.innerHTML = sub.formula_mathml;   // the server's own schema, not user text
  box.append(formula, el("p", { class: "source" }, `Source: ${sub.source}`));
  return box;
}

function swap(list, i, j) {
  const out = list.slice();
  [out[i], out[j]] = [out[j], out[i]];
  return out;
}

export class Controls {
  // addLayer(path, kind): how "Add layer" adds one (the page asks the server for a layer
  // that suits the look); without it, the kind's bare defaults.
  constructor(form, schema, onChange, addLayer = null) {
    this.form = form;
    this.schema = schema;
    this.onChange = onChange;
    this.ctx = { openGroups: new Set(["Fog", "Layers", "Wind", "layers.0"]), addLayer };
  }

  // open the group or list item at `path` (a dotted path) when it is next drawn
  open(path) { this.ctx.openGroups.add(path); }

  // Show `value`. The form is rebuilt only when its shape changes (layers or list items
  // added, removed, reordered or of another kind); otherwise every control is set in
  // place (sync), so that a control being typed into keeps its text and focus.
  render(value) {
    const next = shapeOf(value);
    if (next === this.shape) {
      this.sync(value);
      return;
    }
    this.shape = next;
    // keep the focused control's focus across a rebuild
    const active = document.activeElement;
    const focusPath = active && this.form.contains(active) ? active.dataset.path : null;
    this.form.replaceChildren();
    for (const [name, box] of this.sections(value)) {
      if (box.childElementCount > 1) this.form.append(box);
      else console.warn(`panel section ${name} is empty`);
    }
    if (focusPath) this.form.querySelector(`[data-path="${CSS.escape(focusPath)}"]`)?.focus();
  }

  // The panel's sections (the schema's `groups`, in order), each field placed in the
  // section its `group` names; an object's fields go where the object goes, their labels
  // prefixed by its name when the section is not named for it ("sun azimuth" in Light).
  sections(value) {
    const top = resolve(this.schema, this.schema);
    const boxes = new Map();
    const ctx = this.ctx;
    const section = (name) => {
      if (!boxes.has(name)) {
        const box = el("details", { class: "group section", open: ctx.openGroups.has(name),
          "data-section": name });
        box.addEventListener("toggle", () => {
          if (box.open) ctx.openGroups.add(name); else ctx.openGroups.delete(name);
        });
        box.append(el("summary", {}, name));
        boxes.set(name, box);
      }
      return boxes.get(name);
    };
    for (const g of this.schema.groups || []) section(g);
    const place = (path, prop, v, group, prefix) => {
      const node = resolve(this.schema, prop) || {};
      const g = prop.group || node.group || group || "Scene and quality";
      if ((node.type === "object" || node.properties) && !node.prefixItems) {
        const own = prop.group && prop.group.toLowerCase() !== path.at(-1);
        for (const [name, sub] of Object.entries(node.properties || {})) {
          place([...path, name], sub, v?.[name], g, own ? path.at(-1) : null);
        }
        return;
      }
      const own = prop.title || node.title || path.at(-1).replace(/_/g, " ");
      const shown = { ...prop, title: prefix ? `${prefix[0].toUpperCase()}${prefix.slice(1)} ${own}` : own };
      if (prop.description === undefined && node.description) shown.description = node.description;
      const f = field(this.schema, path, shown, v, this.onChange, ctx);
      if (f) section(g).append(f);
    };
    for (const [name, sub] of Object.entries(top.properties)) {
      if (SKIP.has(name)) continue;
      place([name], sub, value[name], null, null);
    }
    return boxes;
  }

  // Set every control to `value` in place (a camera dragged, a look confirmed), except the
  // one that has focus: its text is the user's until they commit it.
  sync(value) {
    if (shapeOf(value) !== this.shape) return this.render(value);
    const active = document.activeElement;
    for (const e of this.form.querySelectorAll("[data-path]")) {
      if (e === active) continue;
      const v = valueAt(value, e.dataset.path);
      if (v === undefined) continue;
      if (e.type === "checkbox") {
        if (e.checked !== !!v) e.checked = !!v;
        continue;
      }
      const text = Array.isArray(v) ? v.join(", ") : String(v);
      if (e.value !== text) e.value = text;
      const range = e.parentElement?.querySelector('input[type="range"]');
      if (range && e.type === "number") {
        const pos = range.toValueText(text);
        if (range.value !== pos) range.value = pos;
      }
    }
    // the function editors follow their layer too
    for (const ed of this.form.querySelectorAll(".function-editor")) ed.refresh?.(valueAt(value, ed.dataset.path));
  }
}

function valueAt(obj, path) {
  let v = obj;
  for (const key of path.split(".")) {
    if (v == null) return undefined;
    v = Array.isArray(v) ? v[Number(key)] : v[key];
  }
  return v;
}

// The form's structure for `value`: list lengths and each item's kind, not the numbers.
function shapeOf(v) {
  if (Array.isArray(v)) return `[${v.map(shapeOf).join(",")}]`;
  if (v && typeof v === "object") {
    return `{${Object.keys(v).map((k) => `${k}:${k === "kind" ? v[k] : shapeOf(v[k])}`).join(",")}}`;
  }
  return "";
}

// Set `value` at `path` inside a copy of `obj` and return the patch that the server
// merges: objects merge key by key, lists are replaced whole.
export function patchFor(obj, path, value) {
  const patch = {};
  let node = patch;
  let src = obj;
  for (let i = 0; i < path.length; i++) {
    const key = path[i];
    const last = i === path.length - 1;
    if (Array.isArray(src)) {
      // a field inside a list item: the list is sent whole
      const list = structuredClone(src);
      setIn(list, path.slice(i), value);
      return { patch, list, at: path.slice(0, i) };
    }
    if (last) node[key] = value;
    else node = node[key] = {};
    src = src?.[key];
  }
  return { patch };
}

function setIn(obj, path, value) {
  let node = obj;
  for (let i = 0; i < path.length - 1; i++) node = node[path[i]];
  node[path.at(-1)] = value;
}

export function buildPatch(obj, path, value) {
  const r = patchFor(obj, path, value);
  if (!r.list) return r.patch;
  const patch = {};
  let node = patch;
  r.at.forEach((k, i) => {
    if (i === r.at.length - 1) node[k] = r.list;
    else node = node[k] = {};
  });
  return patch;
}

// The cross-field rules of a layer's kind (its schema's x-rules, stated beside the server's
// validator), kept as the user edits one field of `layer`: a field bound from below by
// another ("atLeast": another field, or the sum of |x| over a list's items) is carried up
// with the edit that raised its bound, and an edit that lowers it past its bound stops at
// the bound. Returns the layer as it will be sent and, for each field changed or held,
// a note in words ({ key, text }); the layer unchanged where no rule binds; layer null
// where the bound field cannot follow (it would pass its own most): the edit is not made.
export function keepRules(layer, node, edited) {
  const notes = [];
  const out = { ...layer };
  for (const rule of node?.["x-rules"] || []) {
    const b = rule.atLeast || {};
    const bound = b.field !== undefined ? Number(out[b.field])
      : (out[b.sumAbs[0]] || []).reduce((acc, item) => acc + Math.abs(Number(item[b.sumAbs[1]]) || 0), 0);
    const prop = node.properties?.[rule.field] || {};
    const step = Number(prop.step) || (prop.type === "integer" ? 1 : 0);
    // the server's own comparison, on the same doubles summed in the same order
    if (!(Number(out[rule.field]) < bound)) continue;
    const up = step ? snapUp(bound, step) : bound;
    const name = label(rule.field, prop);
    if (prop.maximum !== undefined && up > prop.maximum) {   // no room: the edit is not made
      return { layer: null, notes: [{ key: edited,
        text: `${name} would have to be ${up}, over its most (${prop.maximum}): ${rule.why}.` }] };
    }
    out[rule.field] = up;
    notes.push({ key: edited === rule.field ? rule.field : edited,
      text: edited === rule.field ? `${name} stops at ${up} here: ${rule.why}. Lower the others first.`
        : `${name} raised to ${up}: ${rule.why}.` });
  }
  return { layer: out, notes };
}

// the least multiple of `step` at or above v, written with step's decimals (one step more
// where the written number falls under v: 0.1 + 0.2 is over 0.3)
function snapUp(v, step) {
  const decimals = Math.max(0, (String(step).split(".")[1] || "").length);
  let r = Number((Math.ceil(v / step - 1e-9) * step).toFixed(decimals));
  if (r < v) r = Number((r + step).toFixed(decimals));
  return r;
}

// the schema of the list item at `path` of `params` (a layer), or null
export function itemSchemaAt(schema, params, listPath, index) {
  let node = resolve(schema, schema);
  for (const k of listPath) node = resolve(schema, node?.properties?.[k]);
  const item = listPath.reduce((v, k) => v?.[k], params)?.[index];
  return node?.items && item ? itemSchema(schema, node, item) : null;
}
