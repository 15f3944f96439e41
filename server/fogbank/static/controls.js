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

function label(name, node) {
  return (node && node.title) || name.replace(/_/g, " ");
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

function numberControl(path, node, value, onChange, integer) {
  const id = `c${uid++}`;
  const min = node.minimum ?? node.exclusiveMinimum ?? (node.exclusiveMinimum === 0 ? 0 : undefined);
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
  let range = null;
  if (min !== undefined && max !== undefined && isFinite(min) && isFinite(max) && max - min <= 1e5) {
    range = el("input", { type: "range", min: String(min), max: String(max), step: String(step),
      value: String(value), "aria-label": `${label(path.at(-1), node)} slider`, tabindex: "-1" });
    range.addEventListener("input", () => { num.value = range.value; onChange(path, Number(range.value)); });
    range.addEventListener("pointerdown", () => onChange.interact?.(true));
    range.addEventListener("pointerup", () => onChange.interact?.(false));
    wrap.append(range);
  }
  num.addEventListener("change", () => {
    if (num.value === "" || !isFinite(Number(num.value))) return;
    if (range) range.value = num.value;
    onChange(path, integer ? Math.round(Number(num.value)) : Number(num.value));
  });
  wrap.append(num, unit);
  return wrap;
}

function vectorControl(path, node, value, onChange) {
  const wrap = el("fieldset", { class: "field vector" }, el("legend", {}, label(path.at(-1), node)));
  if (node.description) wrap.title = node.description;
  const inputs = value.map((v, i) => {
    const inp = el("input", { type: "number", step: "any", value: String(v),
      "aria-label": `${label(path.at(-1), node)} ${"xyzw"[i] ?? i}`, "data-path": `${path.join(".")}.${i}` });
    inp.addEventListener("change", () => {
      const vals = inputs.map((x) => Number(x.value));
      if (vals.every(isFinite)) onChange(path, vals);
    });
    return inp;
  });
  wrap.append(...inputs);
  return wrap;
}

function listOfNumbersControl(path, node, value, onChange) {
  const id = `c${uid++}`;
  const inp = el("input", { id, type: "text", value: value.join(", "), "data-path": path.join("."),
    inputmode: "decimal" });
  inp.addEventListener("change", () => {
    const vals = inp.value.split(/[,\s]+/).filter(Boolean).map(Number);
    if (vals.length && vals.every(isFinite)) onChange(path, vals);
  });
  return el("div", { class: "field text" }, el("label", { for: id, title: node.description || "" },
    label(path.at(-1), node)), inp);
}

function selectControl(path, node, options, value, onChange) {
  const id = `c${uid++}`;
  const sel = el("select", { id, "data-path": path.join(".") });
  for (const o of options) sel.append(el("option", { value: String(o), selected: o === value }, String(o)));
  sel.addEventListener("change", () => {
    const raw = sel.value;
    onChange(path, typeof value === "number" ? Number(raw) : raw);
  });
  return el("div", { class: "field select" }, el("label", { for: id, title: node.description || "" },
    label(path.at(-1), node)), sel);
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
    return el("div", { class: "field check" }, cb, el("label", { for: id, title: node.description || "" },
      label(path.at(-1), node)));
  }
  if (node.type === "number" || node.type === "integer") {
    return numberControl(path, node, value, onChange, node.type === "integer");
  }
  if (node.type === "string" && node.format === "color") {
    const id = `c${uid++}`;
    const inp = el("input", { id, type: "color", value, "data-path": path.join(".") });
    inp.addEventListener("input", () => onChange(path, inp.value));
    return el("div", { class: "field color" }, el("label", { for: id }, label(path.at(-1), node)), inp);
  }
  if (node.type === "array" && node.prefixItems) return vectorControl(path, node, value, onChange);
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
    const name = item.kind ? `${i + 1}. ${item.kind}` : `${i + 1}`;
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
    const kinds = Object.keys(node.items.discriminator.mapping);
    const sel = el("select", { id });
    for (const k of kinds) sel.append(el("option", { value: k }, k));
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
    this.ctx = { openGroups: new Set(["layers.0"]), addLayer };
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
    const top = resolve(this.schema, this.schema);
    this.form.replaceChildren();
    for (const [name, sub] of Object.entries(top.properties)) {
      if (SKIP.has(name)) continue;
      const f = field(this.schema, [name], sub, value[name], this.onChange, this.ctx);
      if (!f) continue;
      if (f.tagName === "DETAILS" && (name === "wind" || name === "layers")) f.open = true;
      this.form.append(f);
    }
    if (focusPath) this.form.querySelector(`[data-path="${CSS.escape(focusPath)}"]`)?.focus();
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
      if (range && e.type === "number" && range.value !== text) range.value = text;
    }
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
