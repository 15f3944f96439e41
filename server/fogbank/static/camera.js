// Camera input on the view: drag to look around (fly) or, with Shift or in orbit mode,
// to orbit a point in front of the camera; wheel and pinch move forward and back;
// W A S D / arrow keys fly, Q and E go down and up. Emits camera patches.

const DEG = Math.PI / 180;

export function forward(cam) {
  const y = cam.yaw * DEG, p = cam.pitch * DEG;
  return [Math.sin(y) * Math.cos(p), Math.sin(p), -Math.cos(y) * Math.cos(p)];
}

export class CameraInput {
  constructor(canvas, getCamera, send, interact) {
    this.canvas = canvas;
    this.getCamera = getCamera;   // the camera as last known (server state + local moves)
    this.send = send;             // send(patch) -> sends {type: "camera", camera: patch}
    this.interact = interact;     // interact(active)
    this.orbitDistance = 60;
    this.keys = new Set();
    this.pointers = new Map();
    this.pinch = null;
    this.raf = 0;
    this.lastKeyTime = 0;
    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", (e) => this.up(e));
    canvas.addEventListener("pointercancel", (e) => this.up(e));
    canvas.addEventListener("wheel", (e) => this.wheel(e), { passive: false });
    canvas.addEventListener("keydown", (e) => this.key(e, true));
    canvas.addEventListener("keyup", (e) => this.key(e, false));
    canvas.addEventListener("blur", () => { this.keys.clear(); this.interact(false); });
    canvas.style.touchAction = "none";
  }

  down(e) {
    this.canvas.focus();
    this.canvas.setPointerCapture(e.pointerId);
    this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, orbit: e.shiftKey || e.button === 2 });
    this.interact(true);
  }

  up(e) {
    this.pointers.delete(e.pointerId);
    this.pinch = null;
    if (this.pointers.size === 0) this.interact(false);
  }

  move(e) {
    const p = this.pointers.get(e.pointerId);
    if (!p) return;
    if (this.pointers.size === 2) {       // pinch: dolly
      const [a, b] = [...this.pointers.values()];
      p.x = e.clientX; p.y = e.clientY;
      const d = Math.hypot(a.x - b.x, a.y - b.y);
      if (this.pinch) this.dolly((d - this.pinch) * 0.2);
      this.pinch = d;
      return;
    }
    const dx = e.clientX - p.x, dy = e.clientY - p.y;
    p.x = e.clientX; p.y = e.clientY;
    const cam = this.getCamera();
    const k = cam.fov / this.canvas.clientHeight;   // degrees per pixel
    if (p.orbit) this.orbit(-dx * k, dy * k);
    else this.look(-dx * k, dy * k);
  }

  look(dyaw, dpitch) {
    const cam = this.getCamera();
    this.send({ yaw: wrap(cam.yaw - dyaw), pitch: clamp(cam.pitch + dpitch, -89, 89) });
  }

  orbit(dyaw, dpitch) {
    const cam = this.getCamera();
    const f = forward(cam);
    const pivot = cam.position.map((v, i) => v + f[i] * this.orbitDistance);
    const yaw = wrap(cam.yaw - dyaw), pitch = clamp(cam.pitch - dpitch, -89, 89);
    const nf = forward({ yaw, pitch });
    const position = pivot.map((v, i) => round(v - nf[i] * this.orbitDistance));
    this.send({ yaw, pitch, position });
  }

  dolly(amount) {
    const cam = this.getCamera();
    const f = forward(cam);
    this.send({ position: cam.position.map((v, i) => round(v + f[i] * amount)) });
  }

  wheel(e) {
    e.preventDefault();
    this.interact(true);
    clearTimeout(this.wheelTimer);
    this.wheelTimer = setTimeout(() => this.interact(false), 200);
    this.dolly(-Math.sign(e.deltaY) * Math.min(20, Math.abs(e.deltaY) * 0.05 + 1));
  }

  key(e, down) {
    const k = e.key.toLowerCase();
    if (!["w", "a", "s", "d", "q", "e", "arrowup", "arrowdown", "arrowleft", "arrowright"].includes(k)) return;
    e.preventDefault();
    if (down) this.keys.add(k); else this.keys.delete(k);
    if (this.keys.size && !this.raf) {
      this.interact(true);
      this.lastKeyTime = performance.now();
      this.raf = requestAnimationFrame((t) => this.tick(t));
    }
  }

  tick(t) {
    const dt = Math.min(0.1, (t - this.lastKeyTime) / 1000);
    this.lastKeyTime = t;
    if (!this.keys.size) {
      this.raf = 0;
      this.interact(false);
      return;
    }
    const cam = this.getCamera();
    const speed = 15 * dt;   // m per frame at 15 m/s
    const f = forward(cam);
    const r = [Math.cos(cam.yaw * DEG), 0, Math.sin(cam.yaw * DEG)];
    const pos = cam.position.slice();
    const has = (...ks) => ks.some((k) => this.keys.has(k));
    const addv = (v, s) => { for (let i = 0; i < 3; i++) pos[i] += v[i] * s; };
    if (has("w", "arrowup")) addv(f, speed);
    if (has("s", "arrowdown")) addv(f, -speed);
    if (has("d")) addv(r, speed);
    if (has("a")) addv(r, -speed);
    if (has("e")) pos[1] += speed;
    if (has("q")) pos[1] -= speed;
    const patch = { position: pos.map(round) };
    if (has("arrowleft")) patch.yaw = wrap(cam.yaw - 60 * dt);
    if (has("arrowright")) patch.yaw = wrap(cam.yaw + 60 * dt);
    this.send(patch);
    this.raf = requestAnimationFrame((t2) => this.tick(t2));
  }
}

function clamp(v, lo, hi) { return Math.max(lo, Math.min(hi, v)); }
function wrap(v) { v = ((v + 180) % 360 + 360) % 360 - 180; return Math.round(v * 100) / 100; }
function round(v) { return Math.round(v * 100) / 100; }
