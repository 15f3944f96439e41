// Compact links: a long look's query as z=<base64url, no padding, of the raw deflate of
// the readable query>, made here with the browser's own CompressionStream (no library).
// The keys that say how the animation plays and where it is (play, speed, time), and the
// framing (aspect), stay readable beside z. The server reads z as the readable query it holds
// (server/fogbank/model/urlstate.py: compact, inflate).

// Past this many characters a link is given compact; shorter looks keep the readable
// link, since people read them. Past 2000 characters nobody reads a link, and many tools
// that carry links (chat, mail, some proxies and old browsers: 2048-8192) start to cut or
// refuse them; compacting shrinks a look's text to 20-65%. Kept equal to urlstate's
// LONG_QUERY (tests/unit/test_urlstate.py checks).
export const LONG_QUERY = 2000;
const BESIDE_Z = new Set(["play", "speed", "aspect", "time"]);

export function isLong(query) {
  return query.replace(/^\?/, "").length > LONG_QUERY;
}

function keyOf(part) {
  const raw = part.split("=", 1)[0].replace(/\+/g, " ");
  try {
    return decodeURIComponent(raw);
  } catch {
    return raw;
  }
}

function base64url(bytes) {
  let bin = "";
  for (let i = 0; i < bytes.length; i += 0x8000) bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(bin).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}

// The compact form of a readable query: "z=..." with play, speed and time beside it. A
// query that is compact already is given back as it is.
export async function compactQuery(query) {
  const parts = query.replace(/^\?/, "").split("&").filter(Boolean);
  if (parts.some((p) => keyOf(p) === "z")) return parts.join("&");
  const inside = parts.filter((p) => !BESIDE_Z.has(keyOf(p)));
  const beside = parts.filter((p) => BESIDE_Z.has(keyOf(p)));
  const deflated = new Blob([inside.join("&")]).stream().pipeThrough(new CompressionStream("deflate-raw"));
  const bytes = new Uint8Array(await new Response(deflated).arrayBuffer());
  return [`z=${base64url(bytes)}`, ...beside].join("&");
}

// The canonical query with its camera keys replaced by `cameraPart` (the server's reply to
// a camera message: its `camera.` keys, server/fogbank/model/urlstate.py encode_field).
// The canonical query writes the look's fields in the params model's order, and only
// `scene` comes before `camera` (after `v` and `preset`), so the camera's keys go right
// after those.
const BEFORE_CAMERA = new Set(["v", "preset", "scene"]);
export function withCamera(query, cameraPart) {
  const parts = query.split("&").filter((p) => p && !keyOf(p).startsWith("camera."));
  let at = 0;
  while (at < parts.length && BEFORE_CAMERA.has(keyOf(parts[at]))) at++;
  parts.splice(at, 0, ...cameraPart.split("&").filter(Boolean));
  return parts.join("&");
}
