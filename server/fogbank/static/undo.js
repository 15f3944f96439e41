// Undo and redo of look changes: a stack of whole looks (params) before each change.
// Changes of the same field within MERGE_MS of each other are one step (a slider drag,
// typing digits), so an undo goes back to before the gesture, not one pixel of it.

const MERGE_MS = 800;
const DEPTH = 100;

export class UndoStack {
  constructor(now = () => performance.now()) {
    this.now = now;
    this.past = [];     // [{params, camera, key, at}], oldest first
    this.future = [];
  }

  // `params` is the look before a change of `key`; `camera` says whether the change
  // moves the camera (a preset, a reset, a typed position), so that undoing it moves it back.
  record(params, key, camera = false) {
    const last = this.past.at(-1);
    const t = this.now();
    this.future = [];
    if (last && last.key === key && t - last.at < MERGE_MS) {
      last.at = t;
      return;
    }
    this.past.push({ params: structuredClone(params), camera, key, at: t });
    if (this.past.length > DEPTH) this.past.shift();
  }

  canUndo() { return this.past.length > 0; }
  canRedo() { return this.future.length > 0; }

  // the look to go back to, given the look now (kept for redo); null when none
  undo(current) {
    const entry = this.past.pop();
    if (!entry) return null;
    this.future.push({ ...entry, params: structuredClone(current) });
    return entry;
  }

  redo(current) {
    const entry = this.future.pop();
    if (!entry) return null;
    this.past.push({ ...entry, params: structuredClone(current), at: -Infinity });
    return entry;
  }
}
