// A still viewer: shows /api/still.jpg for this page's query and lists the presets.
const img = document.getElementById("still");
const status = document.getElementById("status");

function show(query) {
  const size = `width=${Math.min(1920, innerWidth)}&height=${Math.min(1080, Math.round(innerHeight * 0.85))}`;
  status.textContent = "rendering…";
  img.src = `/api/still.jpg?${query ? query + "&" : ""}${size}`;
}

img.addEventListener("load", () => { status.textContent = ""; });
img.addEventListener("error", async () => {
  const r = await fetch(img.src);
  status.textContent = r.ok ? "" : `error: ${await r.text()}`;
});

const presets = await (await fetch("/api/presets")).json();
const nav = document.getElementById("presets");
for (const p of presets) {
  const a = document.createElement("a");
  a.href = `/?${p.query}`;
  a.textContent = p.title;
  a.title = p.description;
  nav.append(a);
}
show(location.search.slice(1));
