// Live sessions (issue 34; server/fogbank/stream/live.py). "Share live" makes a link that
// opens this session for others: they watch its look and camera as they change, drawn once
// for everyone. The presenter sees how many watch and can hand control to one of them (and
// take it back); whoever does not have control watches, the controls read-only. A viewer's
// page is opened with ?live=<token>; a presenter's page connects with a random room (the
// key its load balancer routes by, which becomes the live link's token when shared).

// the token of the live session this page watches (null: the page has a session of its own)
export const liveToken = (() => {
  const t = new URLSearchParams(location.search).get("live");
  return t && /^[A-Za-z0-9_-]{16,64}(\.[A-Za-z0-9_-]{16})?$/.test(t) ? t : null;
})();

// a random room: 16 bytes, URL-safe base64 (22 characters)
export function newRoom() {
  const bytes = crypto.getRandomValues(new Uint8Array(16));
  return btoa(String.fromCharCode(...bytes)).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}

// whether this page may change the look: its own session, or a live one whose control it has
export function canSteer(live) {
  if (!live) return !liveToken;
  return live.role === "presenter" ? live.control == null : live.control != null && live.control === live.you;
}

export const liveLink = (token) => `${location.origin}${location.pathname}?live=${token}`;

// the toolbar's and the view's parts of a live session, following store.live
export function liveUi({ stream, store, $, toast, lookQuery }) {
  // the elements that steer the look (the panel's form, and the toolbar's)
  const steering = ["preset", "play", "speed", "time", "reset-look", "reset-camera"];
  let copyWhenShared = false;

  stream.addEventListener("hello", (e) => {
    if (e.detail.live) store.set({ live: { role: "viewer", you: e.detail.live.id, viewers: 1, control: null } });
  });
  // a page of its own reconnected: a new session, shared by no one (its live link ended)
  stream.addEventListener("open", () => { if (!liveToken) store.set({ live: null }); });
  stream.addEventListener("audience", (e) => {
    const { type, ...live } = e.detail;
    if (store.get().live?.ended) return;   // (one sent as the session ended)
    store.set({ live: live.token ? live : null });
    // a presenter's page reconnects (a blip) with its room and the resume key, which gives
    // it its live session back (stream/live.py resume_live); its viewers wait meanwhile
    if (live.role === "presenter") {
      const room = new URLSearchParams(stream.extra).get("room");
      stream.extra = live.token && live.resume ? `room=${room}&resume=${live.resume}` : `room=${room}`;
    }
    if (live.token && live.role === "presenter" && copyWhenShared) {
      copyWhenShared = false;
      copy(liveLink(live.token), "Live link copied: whoever opens it watches this session");
    }
  });
  // A page that shares nothing reconnects with a fresh room: a load balancer that hashes by
  // the room (the Kubernetes ingress's consistent hash) then picks a replica again, where
  // the old room kept it retrying the one that held it, dead or not, until that one left
  // the endpoints (about 15 s). A presenter keeps its room for its first two tries (a
  // blip: its live session comes back on the replica that holds it), then starts afresh.
  stream.addEventListener("reconnecting", () => {
    if (liveToken) return;   // a viewer: its session is where its token leads
    const live = store.get().live;
    const presenting = live && live.role === "presenter" && live.token && live.resume;
    if (!presenting || stream.retry > 2) stream.extra = `room=${newRoom()}`;
  });
  stream.addEventListener("ended", (e) => {
    store.set({ live: { ...(store.get().live || {}), ended: e.detail.msg, control: null } });
  });
  stream.addEventListener("close", (e) => {
    if (liveToken && (e.detail.code === 4404 || e.detail.code === 4410)) {
      const live = store.get().live || { role: "viewer" };
      store.set({ live: { ...live, ended: live.ended || e.detail.reason || "this live session has ended" } });
    }
  });

  async function copy(text, done) {
    try {
      await navigator.clipboard.writeText(text);
      toast(done);
    } catch {
      prompt("Copy this link", text);
    }
  }
  $("share-live").addEventListener("click", () => {
    const live = store.get().live;
    if (live && live.token) return copy(liveLink(live.token), "Live link copied");
    copyWhenShared = true;
    stream.send({ type: "share" });
  });
  $("live-copy").addEventListener("click", () => copy(liveLink(store.get().live.token), "Live link copied"));
  $("live-stop").addEventListener("click", () => {
    stream.send({ type: "share", active: false });
    $("live").open = false;
  });
  $("live-take").addEventListener("click", () => stream.send({ type: "control", to: null }));
  $("watching-give").addEventListener("click", () => {
    const live = store.get().live;
    if (live && live.ended) {   // the session ended: open the look it ended on, as one's own
      location.href = `${location.pathname}?${lookQuery()}`;
      return;
    }
    stream.send({ type: "control", to: null });
  });

  function show(live) {
    const steer = canSteer(live);
    document.body.classList.toggle("watching", !steer);
    for (const id of steering) $(id).disabled = !steer;
    $("controls").inert = !steer;
    const presenter = live && live.role === "presenter";
    $("share-live").hidden = Boolean(liveToken) || Boolean(presenter);
    $("live").hidden = !presenter;
    if (presenter) {
      const n = live.viewers;
      $("live-summary").textContent = `● Live · ${n} watching`;
      $("live-control").textContent = live.control ? `Viewer ${live.control} has control of the look.`
        : "You have control; hand it to a viewer to let them steer.";
      $("live-link").value = liveLink(live.token);
      $("live-take").hidden = live.control == null;
      const items = (live.ids || []).map((id) => {
        const li = document.createElement("li");
        const name = document.createElement("span");
        name.textContent = `Viewer ${id}`;
        const give = document.createElement("button");
        give.type = "button";
        give.dataset.viewer = id;
        give.textContent = live.control === id ? "Has control" : "Give control";
        give.disabled = live.control === id;
        give.addEventListener("click", () => stream.send({ type: "control", to: id }));
        li.append(name, give);
        return li;
      });
      if (!items.length) {
        const li = document.createElement("li");
        li.className = "empty";
        li.textContent = "No one watches yet: send them the live link";
        items.push(li);
      }
      $("live-viewers").replaceChildren(...items);
    }
    const viewer = liveToken !== null;
    $("watching").hidden = !viewer;
    if (viewer) {
      const give = $("watching-give");
      if (live && live.ended) {
        $("watching-text").textContent = `This live session has ended: ${live.ended}.`.replace("..", ".");
        give.textContent = "Open this look";
        give.hidden = !store.get().confirmed;
      } else if (!live) {
        $("watching-text").textContent = "Joining the live session…";
        give.hidden = true;
      } else {
        const others = Math.max(0, live.viewers - 1);
        const who = steer ? "you have control" : live.control ? "another viewer has control" : "the presenter has control";
        $("watching-text").textContent = `● Watching live · ${others} other${others === 1 ? "" : "s"} watching · ${who}`;
        give.textContent = "Give control back";
        give.hidden = !steer;
      }
    }
  }
  store.subscribe((s, prev) => { if (s.live !== prev.live || s.confirmed !== prev.confirmed) show(s.live); });
  show(store.get().live);
}
