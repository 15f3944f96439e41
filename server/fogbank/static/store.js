// The page's one state store: a plain, frozen object that only set()/update() replace.
// Every part of the page (app.js's stream handlers, the controls' and camera's callbacks,
// the toolbar) reads the state with get() and writes it with set() or update(); views
// follow it with subscribe().

export function createStore(initial) {
  let state = Object.freeze({ ...initial });
  const subscribers = new Set();
  return {
    get: () => state,
    // Merge `patch` into the state (one level deep: a key's value is replaced whole) and
    // tell the subscribers, with the state before, if any key changed. Returns the state.
    set(patch) {
      const prev = state;
      if (Object.keys(patch).every((k) => k in prev && Object.is(prev[k], patch[k]))) return prev;
      state = Object.freeze({ ...prev, ...patch });
      for (const fn of [...subscribers]) fn(state, prev);
      return state;
    },
    // set(fn(state)): for a change computed from the current state.
    update(fn) { return this.set(fn(state)); },
    // fn(state, prev) after every change; returns the function that unsubscribes.
    subscribe(fn) {
      subscribers.add(fn);
      return () => subscribers.delete(fn);
    },
  };
}

export const store = createStore({
  confirmed: null,      // the server's last "state" message: {version, query, params, playing, speed, time, view}
  params: null,         // the look on screen: the confirmed params plus local edits and camera moves
  lastFrame: null,      // the header of the last frame drawn ({frame, version, time, full, ...})
  frames: 0,            // frames drawn since the page loaded
  interacting: false,   // a drag, slider or key flight is under way (the server was told)
  scrubbing: false,     // the time slider is being dragged
  redrawNext: true,     // redraw the form when the next state arrives
  pendingParams: null,  // params patch waiting for the next animation frame
  pendingCamera: null,  // camera patch waiting for the next animation frame
  flushQueued: false,   // an animation frame will send the pending patches
  unsent: null,         // params patch made while disconnected, sent on reconnect
  base: null,           // the preset the look started from (Reset to preset, Reset camera)
  show: "shaded",       // what the frames show: the look, or a view that teaches
  showLayer: 0,         // the layer whose optical depth is shown
  viewStats: null,      // the numbers and legend of the last view that teaches
  probe: false,         // the plot panel follows the ray under the cursor
  link: null,           // the server's last measure of the link: {rate_bps, rtt_ms, stream_bps}
  framing: null,        // the view's aspect (width / height) from the link opened, or null: the window's
  live: null,           // a live session's audience ({role, token, viewers, ids, control, you, ended}; live.js)
});

// Values derived from the state (no second copy is kept).
export const version = (s) => (s.confirmed ? s.confirmed.version : 0);
export const playing = (s) => (s.confirmed ? s.confirmed.playing : true);
export const simTime = (s) => (s.lastFrame ? s.lastFrame.time : 0);
