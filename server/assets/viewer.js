// The zerotile viewer: terrain tiles and object-mesh LODs drawn with three.js, with the
// figures the server sends in its response headers. Everything it asks for is a documented
// route (docs/api.md), so the page doubles as an example client.
//
// `window.zerotile` exposes the last figures and a load counter for the headless-browser
// tests (tests/e2e/clients.mjs), which move the controls and wait for new figures.

import * as THREE from "three";
import { OrbitControls } from "/assets/vendor/OrbitControls.js";

const $ = (id) => document.getElementById(id);

/// At most this many tiles are fetched for one terrain view: enough for a zoom level of the
/// default data, few enough that a slow machine still answers in a second or two.
const MAX_TILES = 16;

/// Controls per LOD method: a slider for the parameter that sets the level of detail. A
/// method the page does not know (added to the server later) still gets the free query box.
/// `value: null` sends no value until the slider is moved: the server's default fits the
/// mesh (an octree's depth depends on it), and its `X-Max-Level` then sets the slider's end.
const METHOD_SLIDERS = {
  curvature: { param: "level", min: 1, max: 3, step: 1, value: 2 },
  silhouette: { param: "level", min: 0, max: 7, step: 1, value: 3 },
  qem: { param: "ratio", min: 0.01, max: 1, step: 0.01, value: 0.25 },
  octree: { param: "level", min: 0, max: 20, step: 1, value: null },
};

/// What the tests read: the last figures, and how many views have finished loading.
const status = { loads: 0, errors: 0, mode: "terrain", figures: {} };
window.zerotile = status;

// ---- scene -------------------------------------------------------------------------------

const view = $("view");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2126);
const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 5000);
const controls = new OrbitControls(camera, renderer.domElement);
scene.add(new THREE.HemisphereLight(0xdde8ff, 0x404030, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(60, 120, 40);
scene.add(sun);
const material = new THREE.MeshStandardMaterial({
  vertexColors: true,
  flatShading: true,
  side: THREE.DoubleSide,
  roughness: 0.9,
});
let shown = null;

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}
window.addEventListener("resize", resize);
resize();
renderer.setAnimationLoop(() => {
  controls.update();
  renderer.render(scene, camera);
});

/// Replaces what is drawn; `frame` re-aims the camera (a new dataset or mesh, not a new LOD):
/// `true` at the whole object, or a box, where part of it is what matters.
function show(object, frame) {
  if (shown) {
    scene.remove(shown);
    shown.traverse((o) => o.geometry && o.geometry.dispose());
  }
  shown = object;
  scene.add(object);
  if (frame) {
    const box = frame === true ? new THREE.Box3().setFromObject(object) : frame;
    const size = box.getSize(new THREE.Vector3()).length();
    const centre = box.getCenter(new THREE.Vector3());
    controls.target.copy(centre);
    camera.position.copy(centre).add(new THREE.Vector3(0.2, 0.55, 0.75).multiplyScalar(size));
    camera.near = size / 1000;
    camera.far = size * 20;
    camera.updateProjectionMatrix();
  }
}

/// Colours by height: low blue-green to high brown-white, so relief reads without lighting.
function heightColours(ys) {
  let lo = Infinity, hi = -Infinity;
  for (const y of ys) { lo = Math.min(lo, y); hi = Math.max(hi, y); }
  const c = new THREE.Color();
  const out = new Float32Array(ys.length * 3);
  ys.forEach((y, i) => {
    const t = hi > lo ? (y - lo) / (hi - lo) : 0.5;
    c.setHSL(0.33 - 0.27 * t, 0.45, 0.3 + 0.45 * t);
    out.set([c.r, c.g, c.b], i * 3);
  });
  return out;
}

function meshObject(positions, indices, colourBy) {
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(positions, 3));
  g.setIndex(indices);
  const ys = [];
  for (let i = colourBy; i < positions.length; i += 3) ys.push(positions[i]);
  g.setAttribute("color", new THREE.Float32BufferAttribute(heightColours(ys), 3));
  g.computeVertexNormals();
  return new THREE.Mesh(g, material);
}

// ---- figures and errors ----------------------------------------------------------------

function fmt(x, digits = 3) {
  if (x === undefined || x === null || Number.isNaN(x)) return "–";
  if (Number.isInteger(x)) return x.toLocaleString("en");
  return Number(x).toPrecision(digits);
}

function figures(f) {
  status.figures = f;
  $("f-tri").textContent = fmt(f.triangles);
  $("f-vert").textContent = fmt(f.vertices);
  $("f-bytes").textContent = fmt(f.bytes);
  $("f-bps-label").textContent = f.bpsLabel;
  $("f-bps").textContent = fmt(f.bps);
  $("f-t-label").textContent = f.tLabel;
  $("f-t").textContent = fmt(f.t);
  $("f-ms").textContent = `${Math.round(f.ms)} ms`;
}

function say(text, isError = false) {
  $("status").textContent = text;
  $("status").classList.toggle("error", isError);
  if (isError) status.errors += 1;
}

/// GET as JSON; a non-2xx answer becomes an Error carrying the server's `message`.
async function getJson(url) {
  const res = await fetch(url);
  const body = await res.text();
  if (!res.ok) {
    let msg = body;
    try { msg = JSON.parse(body).message; } catch { /* not JSON: keep the text */ }
    throw new Error(`${res.status} ${url}: ${msg}`);
  }
  return { json: JSON.parse(body), headers: res.headers, bytes: body.length };
}

// Each load takes a ticket; an answer to an older ticket is dropped, so fast slider moves
// never draw a stale LOD over a newer one.
let ticket = 0;

// ---- terrain -------------------------------------------------------------------------------

let dataset = null;

function tileList(info, z) {
  const ranges = (info.available && info.available[z]) || [];
  const tiles = [];
  for (const r of ranges)
    for (let x = r.startX; x <= r.endX; x++)
      for (let y = r.startY; y <= r.endY; y++) tiles.push([x, y]);
  return tiles;
}

/// The threshold query for the slider: T spans four decades up to the relief; R four
/// decades up to 1 (the whole dataset in view).
function thresholdQuery() {
  const mode = $("t-mode").value;
  const s = Number($("t-value").value);
  $("t-value").disabled = mode === "default";
  if (mode === "default") { $("t-out").textContent = ""; return ""; }
  if (mode === "ratio") {
    const r = 10 ** ((s - 100) / 25);
    $("t-label").textContent = "R";
    $("t-out").textContent = r.toPrecision(2);
    return `ratio=${r.toPrecision(3)}`;
  }
  const [lo, hi] = dataset.height_range || [0, 1000];
  const t = Math.max(hi - lo, 1) * 10 ** ((s - 100) / 25);
  $("t-label").textContent = "T";
  $("t-out").textContent = `${t.toPrecision(2)} m`;
  return `threshold=${t.toPrecision(3)}`;
}

/// A bounds corner (longitude and latitude, or a local grid's column and row) in the tile
/// meshes' x, y: degrees (geodetic), EPSG:3857 metres (mercator), column and minus the row.
function meshXY(info, x, y) {
  if (info.scheme === "mercator") {
    const r = 6378137, rad = Math.PI / 180;
    return [r * x * rad, r * Math.log(Math.tan(Math.PI / 4 + (y * rad) / 2))];
  }
  return info.scheme === "local" ? [x, -y] : [x, y];
}

/// Horizontal metres per unit of the mesh coordinates, so relief has its true proportion. A
/// local grid has no horizontal scale: one sample as one metre drew a 512² terrain-RGB tile
/// of Fuji as a needle, so its samples are stretched until the grid is at least four times
/// as wide as its relief (a plausible shape, said in the status line).
function horizontalScale(info, lat) {
  if (info.scheme === "geodetic") return [111320 * Math.cos((lat * Math.PI) / 180), 110540];
  if (info.scheme === "local") {
    const [w, s, e, n] = info.bounds;
    const [lo, hi] = info.height_range || [0, 0];
    const k = Math.max(1, (4 * (hi - lo)) / Math.max(Math.abs(e - w), Math.abs(n - s), 1));
    return [k, k];
  }
  return [1, 1];
}

async function loadTerrain() {
  const my = ++ticket;
  const t0 = performance.now();
  const z = Number($("zoom").value);
  const tiles = tileList(dataset, z).slice(0, MAX_TILES);
  const q = thresholdQuery();
  say(`loading ${tiles.length} tile(s) of zoom ${z}…`);
  try {
    const base = `/v1/datasets/${dataset.name}/tiles/${z}`;
    const answers = await Promise.all(tiles.map(async ([x, y]) => {
      const mesh = await getJson(`${base}/${x}/${y}.json?${q}`);
      // The EZW prefix the server decodes for this T: its size is the bit rate spent.
      const ezw = await fetch(`${base}/${x}/${y}.ezw?${q}`);
      const ezwBytes = ezw.ok ? (await ezw.arrayBuffer()).byteLength : 0;
      return { ...mesh, ezwBytes };
    }));
    if (my !== ticket) return;
    const [w, s, e, n] = dataset.bounds;
    const [kx, ky] = horizontalScale(dataset, (s + n) / 2);
    // West past east: the data crosses the antimeridian. It is drawn unwrapped, its east edge
    // a turn on, as is every tile west of the meridian opposite the data's middle.
    const turn = dataset.scheme !== "local" && w > e ? 360 : 0;
    const [x0, y0] = meshXY(dataset, w, s), [x1, y1] = meshXY(dataset, e + turn, n);
    const period = meshXY(dataset, turn, 0)[0] - meshXY(dataset, 0, 0)[0];
    const cut = meshXY(dataset, (w + e + turn) / 2 - 180, 0)[0];
    const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    const exag = Number($("exag").value);
    const [lo, hi] = dataset.height_range || [0, 0];
    const toScene = (x, y, h) => new THREE.Vector3(((x - cx) * kx) / 1000, (h * exag) / 1000, (-(y - cy) * ky) / 1000);
    const group = new THREE.Group();
    let triangles = 0, vertices = 0, bytes = 0, ezwBytes = 0, t = NaN;
    for (const a of answers) {
      const p = a.json.positions;
      const out = new Float32Array(p.length);
      let [west, east] = [Infinity, -Infinity];
      for (let i = 0; i < p.length; i += 3) [west, east] = [Math.min(west, p[i]), Math.max(east, p[i])];
      const shift = period && (west + east) / 2 < cut ? period : 0;
      // Zerotile meshes are z-up; three.js is y-up: (x, y, z) → (x, z, −y), in km.
      for (let i = 0; i < p.length; i += 3) {
        out[i] = ((p[i] + shift - cx) * kx) / 1000;
        out[i + 1] = (p[i + 2] * exag) / 1000;
        out[i + 2] = (-(p[i + 1] - cy) * ky) / 1000;
      }
      group.add(meshObject(out, a.json.indices, 1));
      triangles += Number(a.headers.get("x-triangles"));
      vertices += p.length / 3;
      bytes += a.bytes;
      ezwBytes += a.ezwBytes;
      t = Number(a.headers.get("x-threshold"));
    }
    const side = dataset.tile_side || 257;
    figures({
      triangles, vertices, bytes, t, ms: performance.now() - t0,
      bps: (ezwBytes * 8) / (tiles.length * side * side),
      bpsLabel: "bits/sample (EZW)", tLabel: "T (m)",
    });
    // A new dataset or zoom: aim at the data, not at the whole tiles (a small dataset's tiles
    // are mostly fill), with a margin so the data's near edge is in view too.
    const key = `${dataset.name}/${z}`;
    let aim = false;
    if (shownKey !== key) {
      const data = new THREE.Box3().setFromPoints([toScene(x0, y0, lo), toScene(x1, y1, hi)]);
      const both = new THREE.Box3().setFromObject(group).intersect(data);
      aim = both.isEmpty() ? true : both.expandByVector(both.getSize(new THREE.Vector3()).multiplyScalar(0.2));
    }
    show(group, aim);
    shownKey = key;
    const scale = dataset.scheme === "local" && kx > 1
      ? ` (a local grid has no horizontal scale: drawn ${kx.toPrecision(2)} m a sample)` : "";
    say(`${dataset.name}: ${tiles.length} tile(s) at zoom ${z}${scale}`);
    status.loads += 1;
  } catch (e) {
    if (my === ticket) say(String(e.message || e), true);
  }
}
let shownKey = null;

async function pickDataset() {
  const name = $("dataset").value;
  if (!name) return;
  dataset = (await getJson(`/v1/datasets/${name}`)).json;
  const zoom = $("zoom");
  zoom.innerHTML = "";
  for (let z = dataset.minzoom; z <= dataset.maxzoom; z++) {
    const n = tileList(dataset, z).length;
    if (n === 0 || n > MAX_TILES) continue;
    zoom.add(new Option(`${z} (${n} tile${n > 1 ? "s" : ""})`, String(z)));
  }
  // Start at the deepest zoom of at most 4 tiles: detailed, yet a first load of a few MB.
  const counts = [...zoom.options].map((o) => tileList(dataset, Number(o.value)).length);
  const start = counts.findLastIndex((n) => n <= 4);
  zoom.selectedIndex = start >= 0 ? start : 0;
  shownKey = null;
  await loadTerrain();
}

// ---- object meshes ---------------------------------------------------------------------------

let meshInfo = null;

function methodUrl(entry) {
  return typeof entry === "string" ? entry : entry.url;
}

function renderMethodControls() {
  const method = $("method").value;
  const box = $("method-params");
  box.innerHTML = "";
  const entry = meshInfo.methods[method];
  $("method-help").textContent = typeof entry === "object" && entry.params ? `takes: ${entry.params}` : "";
  const s = METHOD_SLIDERS[method];
  if (s) {
    const label = document.createElement("label");
    const start = s.value ?? s.min;
    label.innerHTML = `${s.param} <input id="m-value" type="range" min="${s.min}" max="${s.max}" step="${s.step}" value="${start}"> <output id="m-out">${s.value ?? "default"}</output>`;
    box.appendChild(label);
    const input = label.querySelector("input");
    input.dataset.moved = s.value === null ? "" : "1";
    input.addEventListener("input", (e) => {
      e.target.dataset.moved = "1";
      $("m-out").textContent = e.target.value;
      loadMesh(false);
    });
  }
  if (method !== "original") {
    const extra = document.createElement("label");
    extra.innerHTML = `extra query <input id="m-extra" type="text" placeholder="${method === "octree" ? "roi=…" : "e.g. error=0.01"}">`;
    box.appendChild(extra);
    extra.querySelector("input").addEventListener("change", () => loadMesh(false));
  }
}

/// Ends a level slider at the mesh's deepest level, and shows the level the server chose
/// while the slider has not been moved.
function fitSlider(slider, headers) {
  if (!slider) return;
  const deepest = headers.get("x-max-level");
  if (deepest !== null) {
    slider.max = deepest;
    if (Number(slider.value) > Number(deepest)) slider.value = deepest;
  }
  const drawn = headers.get("x-error");
  if (!slider.dataset.moved && drawn !== null) {
    slider.value = drawn;
    $("m-out").textContent = drawn;
  }
}

async function loadMesh(frame) {
  const my = ++ticket;
  const t0 = performance.now();
  const method = $("method").value;
  const params = new URLSearchParams();
  const s = METHOD_SLIDERS[method];
  const slider = $("m-value");
  if (s && slider && slider.dataset.moved) params.set(s.param, slider.value);
  const extra = $("m-extra") && $("m-extra").value.trim();
  if (extra) for (const [k, v] of new URLSearchParams(extra)) params.set(k, v);
  params.set("format", "json");
  say(`loading ${meshInfo.name} ${method}…`);
  try {
    const a = await getJson(`${methodUrl(meshInfo.methods[method])}?${params}`);
    if (my !== ticket) return;
    fitSlider(slider, a.headers);
    const faces = Number(a.headers.get("x-faces") ?? a.json.indices.length / 3);
    figures({
      triangles: faces,
      vertices: Number(a.headers.get("x-vertices") ?? a.json.positions.length / 3),
      bytes: a.bytes,
      bps: (a.bytes * 8) / Math.max(faces, 1),
      bpsLabel: "bits/triangle (JSON)",
      t: a.headers.get("x-error") === null ? NaN : Number(a.headers.get("x-error")),
      tLabel: "error (X-Error)",
      ms: performance.now() - t0,
    });
    // Objects are normalised to a 100-unit diagonal so every mesh frames alike.
    const [lo, hi] = meshInfo.bbox;
    const k = 100 / Math.max(meshInfo.diagonal, 1e-9);
    const p = a.json.positions.map((v, i) => (v - (lo[i % 3] + hi[i % 3]) / 2) * k);
    show(meshObject(p, a.json.indices, 1), frame);
    say(`${meshInfo.name} · ${method}`);
    status.loads += 1;
  } catch (e) {
    if (my === ticket) say(String(e.message || e), true);
  }
}

async function pickMesh() {
  const name = $("mesh").value;
  if (!name) return;
  meshInfo = (await getJson(`/v1/meshes/${name}`)).json;
  const sel = $("method");
  const previous = sel.value;
  sel.innerHTML = "";
  // The server's own list: a method added later (e.g. octree) appears without a page change.
  for (const m of Object.keys(meshInfo.methods)) sel.add(new Option(m, m));
  sel.value = previous && meshInfo.methods[previous] ? previous : Object.keys(meshInfo.methods).find((m) => m !== "original") || "original";
  renderMethodControls();
  await loadMesh(true);
}

// ---- wiring ------------------------------------------------------------------------------------

function setMode(mode) {
  status.mode = mode;
  $("tab-terrain").classList.toggle("on", mode === "terrain");
  $("tab-mesh").classList.toggle("on", mode === "mesh");
  $("terrain-controls").hidden = mode !== "terrain";
  $("mesh-controls").hidden = mode !== "mesh";
  if (mode === "terrain") { shownKey = null; return dataset ? loadTerrain() : pickDataset(); }
  return meshInfo ? loadMesh(true) : pickMesh();
}

async function main() {
  $("tab-terrain").onclick = () => setMode("terrain");
  $("tab-mesh").onclick = () => setMode("mesh");
  $("dataset").onchange = pickDataset;
  $("zoom").onchange = loadTerrain;
  $("t-mode").onchange = loadTerrain;
  $("t-value").oninput = loadTerrain;
  $("exag").oninput = loadTerrain;
  $("mesh").onchange = pickMesh;
  $("method").onchange = () => { renderMethodControls(); loadMesh(false); };
  $("wire").onchange = (e) => { material.wireframe = e.target.checked; };

  const [ds, ms] = await Promise.all([getJson("/v1/datasets"), getJson("/v1/meshes")]);
  for (const d of ds.json.datasets) $("dataset").add(new Option(`${d.name} (${d.scheme})`, d.name));
  for (const m of ms.json.meshes) $("mesh").add(new Option(`${m.name} (${m.faces} faces)`, m.name));
  const wanted = new URLSearchParams(location.search);
  if (wanted.get("dataset")) $("dataset").value = wanted.get("dataset");
  if (wanted.get("mesh")) $("mesh").value = wanted.get("mesh");
  if (wanted.get("mode") === "mesh" || ds.json.datasets.length === 0) return setMode("mesh");
  return setMode("terrain");
}

main().catch((e) => say(String(e.message || e), true));
