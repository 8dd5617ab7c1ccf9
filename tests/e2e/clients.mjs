// Real clients against a running `zerotile serve`, in headless Chromium (playwright-core):
//   cesium   CesiumJS' CesiumTerrainProvider on a geodetic dataset's layer.json
//   maplibre MapLibre GL JS raster-dem (terrain + hillshade) on a mercator dataset's PNG tiles
//            (the terrain source by its tiles.json alone)
//   viewer   our own page at `/`: terrain and mesh views, controls change the triangle count
//   static   CesiumJS on a `zerotile export --format terrain` tree (--static DIR) served by a
//            plain static file server on another origin, as a CDN would: heights sampled from
//            it must match --expect ([[lon, lat, metres], ...], the source's heights above the
//            WGS84 ellipsoid, where Cesium draws) within the deepest level's geometric error
//   static-png  MapLibre GL JS on a `zerotile export --format png --base-url
//            http://cdn.invalid/rgb` tree of the --mercator dataset (--static-png DIR), served
//            the same way: the terrain source is only `url: "http://cdn.invalid/rgb/tiles.json"`
//            and the map's transformRequest maps that placeholder to the real host; the tiles
//            must come by the TileJSON's ?v= template, and queryTerrainElevation at --expect
//            (from the deepest zoom's tiles) must be within that zoom's default threshold plus
//            the PNG's resampling slack
//   static-3dtiles  CesiumJS's Cesium3DTileset on a `zerotile export --format 3dtiles` tree
//            of the same dataset (--static-3dtiles DIR, beside --static's), served the same
//            way: heights sampled from the tileset's most detailed tiles at --expect must be
//            those sampled from the --static tree's deepest level (the same meshes, one drawn
//            on the ellipsoid by quantized-mesh, the other placed in ENU by the tile
//            transforms) within 1 m; --static checks those against --expect
// Each saves a screenshot under --out and fails if it is blank or the client logged errors.
//
//   node tests/e2e/clients.mjs --base http://127.0.0.1:8080 --geodetic demo-ridges \
//        --mercator n44m --out target/e2e [--only cesium,maplibre,viewer] \
//        [--static DIR] [--static-png DIR] [--static-3dtiles DIR] [--expect '[[-71.3,44.27,1822]]']
//        [--expect-png '[[-71.3,44.27,1850]]']  (static-png's points; default --expect's)
//
// CesiumJS and MapLibre are served from web/node_modules by a small static server started
// here (they are not embedded in zerotile). Exit status 0 = every client passed.

import { createServer } from "node:http";
import { createReadStream, mkdirSync, statSync, writeFileSync } from "node:fs";
import { dirname, extname, join, normalize } from "node:path";
import { createRequire } from "node:module";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const web = join(here, "..", "..", "web");
const require = createRequire(join(web, "package.json"));
const { chromium } = require("playwright-core");

const args = Object.fromEntries(
  process.argv.slice(2).reduce((acc, a, i, all) => (a.startsWith("--") ? [...acc, [a.slice(2), all[i + 1]]] : acc), []),
);
const base = (args.base || "http://127.0.0.1:8080").replace(/\/$/, "");
const out = args.out || "target/e2e";
const only = (args.only || ["cesium,maplibre,viewer", args.static && "static", args["static-png"] && "static-png",
  args["static-3dtiles"] && "static-3dtiles"]
  .filter(Boolean).join(",")).split(",");
mkdirSync(out, { recursive: true });

// ---- a static server for the client libraries and their test pages ------------------------

const TYPES = { ".js": "text/javascript", ".css": "text/css", ".json": "application/json", ".html": "text/html",
  ".png": "image/png", ".jpg": "image/jpeg", ".svg": "image/svg+xml", ".wasm": "application/wasm", ".xml": "application/xml" };
const pages = {};
const statics = createServer((req, res) => {
  const path = decodeURIComponent(new URL(req.url, "http://x").pathname);
  if (pages[path]) {
    res.writeHead(200, { "content-type": "text/html" });
    return res.end(pages[path]);
  }
  const file = normalize(join(web, path));
  if (!path.startsWith("/node_modules/") || !file.startsWith(join(web, "node_modules"))) {
    res.writeHead(404);
    return res.end();
  }
  try {
    if (!statSync(file).isFile()) throw new Error("not a file");
  } catch {
    res.writeHead(404);
    return res.end();
  }
  res.writeHead(200, { "content-type": TYPES[extname(file)] || "application/octet-stream" });
  createReadStream(file).pipe(res);
});
await new Promise((ok) => statics.listen(0, "127.0.0.1", ok));
const local = `http://127.0.0.1:${statics.address().port}`;

// ---- a plain file server for an exported tree: another origin, as a CDN is ----------------

// What a static host does: the path names a file (the query string is ignored), the type
// comes from the extension, no content negotiation, and CORS open to any page (a CDN in front
// of the tiles must send Access-Control-Allow-Origin, or CesiumJS and MapLibre cannot read
// them). One per exported tree, on its own port: `origin` is where it is, `log` what it was
// asked for.
const hosts = [];
async function host(dir) {
  const root = normalize(dir);
  const log = [];
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, "http://x").pathname);
    const file = normalize(join(root, path));
    log.push(`${req.url}`);
    const headers = { "access-control-allow-origin": "*" };
    let ok = file.startsWith(root);
    try {
      ok = ok && statSync(file).isFile();
    } catch {
      ok = false;
    }
    if (!ok) {
      res.writeHead(404, headers);
      return res.end();
    }
    res.writeHead(200, { ...headers, "content-type": TYPES[extname(file)] || "application/octet-stream" });
    createReadStream(file).pipe(res);
  });
  await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
  hosts.push(server);
  return { origin: `http://127.0.0.1:${server.address().port}`, log };
}

// ---- the browser ------------------------------------------------------------------------------

// SwiftShader gives WebGL without a GPU (CI machines and containers have none).
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox", "--use-angle=swiftshader", "--use-gl=angle", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
});

/// A page that records console errors, page errors, failed requests and 4xx/5xx answers.
async function open(name) {
  const page = await browser.newPage({ viewport: { width: 960, height: 600 } });
  const problems = [];
  const requests = [];
  page.on("console", (m) => { if (m.type() === "error") problems.push(`console: ${m.text()}`); });
  page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
  page.on("requestfailed", (r) => problems.push(`request failed: ${r.url()} ${r.failure()?.errorText}`));
  page.on("request", (r) => requests.push(r.url()));
  page.on("response", (r) => { if (r.status() >= 400) problems.push(`HTTP ${r.status()}: ${r.url()}`); });
  return { page, problems, requests, name };
}

/// Luminance standard deviation and distinct colours of a screenshot, measured in the browser
/// (no PNG decoder needed here). A blank or single-colour frame has deviation ≈ 0.
async function pixelStats(png) {
  const page = await browser.newPage();
  const stats = await page.evaluate(async (b64) => {
    const img = new Image();
    img.src = `data:image/png;base64,${b64}`;
    await img.decode();
    const c = document.createElement("canvas");
    c.width = img.width; c.height = img.height;
    const g = c.getContext("2d");
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let s = 0, s2 = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
      const y = 0.299 * d[i] + 0.587 * d[i + 1] + 0.114 * d[i + 2];
      s += y; s2 += y * y;
      if (colours.size < 5000) colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    }
    const n = d.length / 4;
    return { std: Math.sqrt(Math.max(s2 / n - (s / n) ** 2, 0)), colours: colours.size };
  }, png.toString("base64"));
  await page.close();
  return stats;
}

/// Saves the screenshot and fails unless it has real content; `area` limits it to an element.
async function shoot(c, file, area) {
  const png = await (area ? c.page.locator(area).screenshot() : c.page.screenshot());
  writeFileSync(join(out, file), png);
  const s = await pixelStats(png);
  console.log(`${c.name}: ${file}: luminance std ${s.std.toFixed(1)}, ${s.colours} colours`);
  check(s.std > 6 && s.colours > 50, `${c.name}: ${file} looks blank (std ${s.std.toFixed(1)}, ${s.colours} colours)`);
}

let failures = 0;
function check(ok, what) {
  if (!ok) { failures += 1; console.error(`FAIL ${what}`); }
}
function noProblems(c) {
  for (const p of c.problems) console.error(`  ${c.name}: ${p}`);
  check(c.problems.length === 0, `${c.name}: ${c.problems.length} error(s) in the browser`);
}

// A page holding one MapLibre map, `window.map`, in #m: `options` is the rest of the Map's
// options (source text), `before` and `after` more script around it. Map errors collect in
// window.mapErrors; window.idle turns true at the first idle; the drawing buffer is kept
// for screenshots.
function maplibrePage({ before = "", options, after = "" }) {
  return `<!doctype html><html><head>
<link rel="icon" href="data:,">
<link rel="stylesheet" href="/node_modules/maplibre-gl/dist/maplibre-gl.css">
<style>html,body,#m{margin:0;width:100%;height:100%}</style>
<script src="/node_modules/maplibre-gl/dist/maplibre-gl.js"></script></head><body><div id="m"></div>
<script>
window.mapErrors = [];
${before}
const map = new maplibregl.Map({
  container: "m", canvasContextAttributes: { preserveDrawingBuffer: true }, preserveDrawingBuffer: true,
  ${options}
});
map.on("error", (e) => { window.mapErrors.push(String(e.error && e.error.message || e)); });
map.on("idle", () => { window.idle = true; });
window.map = map;
${after}
</script></body></html>`;
}

async function describe(name) {
  const res = await fetch(`${base}/v1/datasets/${name}`);
  if (!res.ok) throw new Error(`GET /v1/datasets/${name}: ${res.status} ${await res.text()}`);
  return res.json();
}

// ---- (a) CesiumJS -----------------------------------------------------------------------------

// Waits until Cesium has drawn the view it was just given and loaded its tiles. Its
// `tilesLoaded` still describes the last view until a frame has selected tiles for the new
// one, and on a loaded machine a frame can take longer than any fixed pause (a 56 km view
// once asked for nothing: the check ran before the first frame), so a few frames (counted
// by `ztFrames`, which each page's viewer bumps after rendering) come first.
async function settle(page) {
  const from = await page.evaluate(() => window.ztFrames);
  await page.waitForFunction((f) => window.ztFrames >= f + 3, from, { timeout: 60000, polling: 100 });
  await page.waitForFunction(() => window.viewer.scene.globe.tilesLoaded, null, { timeout: 60000, polling: 250 });
  await page.waitForTimeout(500);
  await page.waitForFunction(() => window.viewer.scene.globe.tilesLoaded, null, { timeout: 60000, polling: 250 });
}

async function cesium() {
  const info = await describe(args.geodetic || "demo-ridges");
  const [w, s, e, n] = info.bounds;
  pages["/cesium.html"] = `<!doctype html><html><head>
<link rel="icon" href="data:,">
<link rel="stylesheet" href="/node_modules/cesium/Build/Cesium/Widgets/widgets.css">
<style>html,body,#c{margin:0;width:100%;height:100%;overflow:hidden}</style>
<script>window.CESIUM_BASE_URL = "/node_modules/cesium/Build/Cesium/";</script>
<script src="/node_modules/cesium/Build/Cesium/Cesium.js"></script></head><body><div id="c"></div>
<script>
(async () => {
  window.tileErrors = [];
  const terrainProvider = await Cesium.CesiumTerrainProvider.fromUrl(${JSON.stringify(`${base}/v1/datasets/${info.name}/`)},
    { requestVertexNormals: true });
  terrainProvider.errorEvent.addEventListener((e) => window.tileErrors.push(String(e.message)));
  // Offline imagery shipped inside the cesium package (no Ion, no network).
  const imagery = await Cesium.TileMapServiceImageryProvider.fromUrl(Cesium.buildModuleUrl("Assets/Textures/NaturalEarthII"));
  const viewer = new Cesium.Viewer("c", {
    terrainProvider, baseLayer: new Cesium.ImageryLayer(imagery), baseLayerPicker: false, geocoder: false,
    animation: false, timeline: false, homeButton: false, sceneModePicker: false, navigationHelpButton: false,
    fullscreenButton: false, infoBox: false, selectionIndicator: false, requestRenderMode: false,
  });
  // A low sun from the west shades the relief (with the tiles' oct-encoded normals), so the
  // screenshot shows the terrain, not a flat texture.
  viewer.scene.light = new Cesium.DirectionalLight({ direction: new Cesium.Cartesian3(0.6, -0.2, -0.5) });
  viewer.scene.globe.enableLighting = true;
  viewer.scene.globe.terrainExaggeration = 2.0;
  window.viewer = viewer;
  window.ztFrames = 0;
  viewer.scene.postRender.addEventListener(() => { window.ztFrames += 1; });
  window.fly = (lon, lat, height) => viewer.camera.setView({
    destination: Cesium.Cartesian3.fromDegrees(lon, lat, height),
    orientation: { heading: 0, pitch: Cesium.Math.toRadians(-35), roll: 0 } });
  window.ready = true;
})().catch((e) => { console.error("setup: " + e); });
</script></body></html>`;
  const c = await open("cesium");
  await c.page.goto(`${local}/cesium.html`);
  await c.page.waitForFunction(() => window.ready === true, null, { timeout: 60000 });
  const lon = (w + e) / 2, lat = (s + n) / 2;
  const span = Math.max(e - w, n - s) * 111000;
  const perZoom = [];
  // From far to near, looking north at the dataset from south of it (pitch −35°, so the
  // camera sits height / tan 35° ≈ 1.43 · height south of the centre).
  for (const height of [span * 15, span * 2, span * 0.4]) {
    const before = c.requests.length;
    await c.page.evaluate(([a, b, h]) => window.fly(a, b, h), [lon, lat - (height * 1.43) / 111000, height]);
    await settle(c.page);
    const zooms = {};
    for (const u of c.requests.slice(before)) {
      const m = u.match(/\/tiles\/(\d+)\/\d+\/\d+\.terrain/);
      if (m) zooms[m[1]] = (zooms[m[1]] || 0) + 1;
    }
    perZoom.push(zooms);
    console.log(`cesium: camera at ${(height / 1000).toFixed(0)} km: .terrain requests per zoom ${JSON.stringify(zooms)}`);
  }
  const deepest = (z) => Math.max(-1, ...Object.keys(z).map(Number));
  const all = {};
  for (const z of perZoom) for (const [k, v] of Object.entries(z)) all[k] = (all[k] || 0) + v;
  check(Object.keys(all).length > 0, "cesium: no .terrain tile was requested");
  // Cesium keeps tiles it has, so a step asks only for what is new: compare the deepest
  // level of the far view with the deepest asked for by the nearer ones.
  const far = deepest(perZoom[0]);
  const near = Math.max(deepest(perZoom[1]), deepest(perZoom[2]));
  check(near > far, `cesium: moving the camera closer did not request deeper levels (${JSON.stringify(perZoom)})`);
  const tileErrors = await c.page.evaluate(() => window.tileErrors);
  for (const t of tileErrors) c.problems.push(`terrain provider: ${t}`);
  await shoot(c, "cesium.png");
  noProblems(c);
  await c.page.close();
}

// ---- (b) MapLibre GL JS -------------------------------------------------------------------

async function maplibre() {
  const info = await describe(args.mercator || "n44m");
  const [w, s, e, n] = info.bounds;
  const tiles = `${base}/v1/datasets/${info.name}/tiles/{z}/{x}/{y}.png`;
  // Both ways of pointing MapLibre at the tiles: the terrain by the dataset's TileJSON alone
  // (it carries the zooms, bounds, size and encoding), the hillshade with them spelled out.
  const dem = { type: "raster-dem", url: `${base}${info.tilejson}` };
  const hills = { type: "raster-dem", tiles: [tiles], tileSize: 512, encoding: "mapbox", bounds: info.bounds,
    minzoom: info.minzoom, maxzoom: info.maxzoom };
  pages["/maplibre.html"] = maplibrePage({ options: `
  center: [${(w + e) / 2}, ${(s + n) / 2}], zoom: ${Math.max(info.maxzoom - 0.5, 1)}, pitch: 60, bearing: 20,
  style: { version: 8,
    sources: { dem: ${JSON.stringify(dem)}, hills: ${JSON.stringify(hills)} },
    layers: [
      { id: "bg", type: "background", paint: { "background-color": "#d8d2c4" } },
      { id: "hillshade", type: "hillshade", source: "hills", paint: { "hillshade-exaggeration": 0.8 } },
    ],
    terrain: { source: "dem", exaggeration: 1.5 } },` });
  const c = await open("maplibre");
  await c.page.goto(`${local}/maplibre.html`);
  await c.page.waitForFunction(() => window.idle === true, null, { timeout: 90000, polling: 250 });
  const pngs = c.requests.filter((u) => /\/tiles\/\d+\/\d+\/\d+\.png/.test(u));
  console.log(`maplibre: ${pngs.length} terrain-RGB tile request(s), terrain ${await c.page.evaluate(() => !!window.map.getTerrain())}`);
  check(pngs.length > 0, "maplibre: no terrain-RGB tile was requested");
  // The TileJSON source asked for its tiles by the document's (versioned) template.
  check(pngs.some((u) => /\.png\?v=[0-9a-f]{16}$/.test(u)), "maplibre: no tile was requested through tiles.json");
  check(await c.page.evaluate(() => !!window.map.getTerrain()), "maplibre: terrain is not on");
  for (const t of await c.page.evaluate(() => window.mapErrors)) c.problems.push(`map error: ${t}`);
  await shoot(c, "maplibre.png");
  noProblems(c);
  await c.page.close();
}

// ---- (c) our viewer --------------------------------------------------------------------------

async function viewer() {
  const c = await open("viewer");
  const loads = () => c.page.evaluate(() => window.zerotile && window.zerotile.loads);
  const figures = () => c.page.evaluate(() => window.zerotile.figures);
  /// Runs `act`, then waits until the page has finished one more load.
  async function after(act) {
    const n = await loads();
    await act();
    await c.page.waitForFunction((k) => window.zerotile.loads > k, n, { timeout: 60000, polling: 100 });
    await c.page.waitForTimeout(300);
    return figures();
  }
  const setRange = (sel, v) => c.page.$eval(sel, (el, val) => {
    el.value = String(val);
    el.dispatchEvent(new Event("input", { bubbles: true }));
  }, v);

  await c.page.goto(`${base}/${args.geodetic ? `?dataset=${args.geodetic}` : ""}`);
  await c.page.waitForFunction(() => window.zerotile && window.zerotile.loads >= 1, null, { timeout: 60000 });
  await c.page.waitForTimeout(300);
  const coarse = await after(() => setRange("#t-value", 40));
  const fine = await after(() => setRange("#t-value", 20));
  console.log(`viewer: terrain triangles ${coarse.triangles} at T ${coarse.t} m, ${fine.triangles} at T ${fine.t} m`);
  check(fine.t < coarse.t, `viewer: the slider did not lower T (${coarse.t} -> ${fine.t})`);
  check(fine.triangles > coarse.triangles, `viewer: a lower T did not give more triangles (${coarse.triangles} -> ${fine.triangles})`);
  await shoot(c, "viewer-terrain.png");

  const first = await after(() => c.page.click("#tab-mesh"));
  const methods = await c.page.$$eval("#method option", (os) => os.map((o) => o.value));
  console.log(`viewer: mesh methods offered ${methods.join(", ")}; ${first.triangles} faces first`);
  for (const m of ["curvature", "silhouette", "qem"]) check(methods.includes(m), `viewer: method ${m} not offered`);
  await after(() => c.page.selectOption("#method", "qem"));
  const few = await after(() => setRange("#m-value", 0.05));
  const many = await after(() => setRange("#m-value", 0.8));
  console.log(`viewer: qem faces ${few.triangles} at ratio 0.05, ${many.triangles} at ratio 0.8`);
  check(many.triangles > few.triangles, `viewer: the QEM slider did not change the face count (${few.triangles} -> ${many.triangles})`);
  await after(() => c.page.selectOption("#method", "silhouette"));
  const s2 = await after(() => setRange("#m-value", 2));
  const s6 = await after(() => setRange("#m-value", 6));
  console.log(`viewer: silhouette faces ${s2.triangles} at level 2, ${s6.triangles} at level 6`);
  check(s6.triangles !== s2.triangles, `viewer: the silhouette level did not change the face count (${s2.triangles})`);
  if (methods.includes("octree")) {
    // The slider starts at the server's default level and ends at the mesh's deepest
    // (X-Max-Level), so every position it offers is a level the mesh has.
    const o = await after(() => c.page.selectOption("#method", "octree"));
    const [start, deepest] = await c.page.$eval("#m-value", (el) => [Number(el.value), Number(el.max)]);
    const od = await after(() => setRange("#m-value", deepest));
    console.log(`viewer: octree faces ${o.triangles} at the default level ${start}, ${od.triangles} at the deepest, ${deepest}`);
    // Before the first answer the slider ends at the octree depth limit, 20: a mesh that deep
    // would be a 400 at its end, counted in the page errors checked below.
    check(deepest >= start && deepest < 20, `viewer: the octree slider does not end at the mesh's deepest level (${start}..${deepest})`);
    check(deepest === start || od.triangles > o.triangles, `viewer: the deepest octree level did not add faces (${o.triangles} -> ${od.triangles})`);
  }
  await c.page.check("#wire");
  await c.page.waitForTimeout(300);
  await shoot(c, "viewer-mesh.png");
  const errs = await c.page.evaluate(() => window.zerotile.errors);
  check(errs === 0, `viewer: ${errs} error(s) shown on the page`);
  noProblems(c);
  await c.page.close();
}

// ---- (d) CesiumJS on a static export ------------------------------------------------------

// An empty page with CesiumJS loaded and a #c for a viewer: the static checks script it.
const CESIUM_PAGE = `<!doctype html><html><head>
<link rel="icon" href="data:,">
<script>window.CESIUM_BASE_URL = "/node_modules/cesium/Build/Cesium/";</script>
<link rel="stylesheet" href="/node_modules/cesium/Build/Cesium/Widgets/widgets.css">
<style>html,body,#c{margin:0;width:100%;height:100%;overflow:hidden}</style>
<script src="/node_modules/cesium/Build/Cesium/Cesium.js"></script></head><body><div id="c"></div></body></html>`;

async function staticExport() {
  const cdn = await host(args.static);
  const tiles = `${cdn.origin}/`;
  const expect = JSON.parse(args.expect || "[]");
  check(expect.length > 0, "static: no --expect points to compare");
  pages["/static.html"] = CESIUM_PAGE;
  const c = await open("static");
  await c.page.goto(`${local}/static.html`);
  const r = await c.page.evaluate(async ([url, points]) => {
    const provider = await Cesium.CesiumTerrainProvider.fromUrl(url, { requestVertexNormals: true });
    const tileErrors = [];
    provider.errorEvent.addEventListener((e) => tileErrors.push(String(e.message)));
    const maxLevel = provider.availability._maximumLevel;
    // One deepest-level tile over the first point, decoded and meshed as the globe would.
    const first = Cesium.Cartographic.fromDegrees(points[0][0], points[0][1]);
    const xy = provider.tilingScheme.positionToTileXY(first, maxLevel);
    const data = await provider.requestTileGeometry(xy.x, xy.y, maxLevel);
    const mesh = await data.createMesh({ tilingScheme: provider.tilingScheme, x: xy.x, y: xy.y, level: maxLevel,
      exaggeration: 1, exaggerationRelativeHeight: 0 });
    const sampled = await Cesium.sampleTerrainMostDetailed(provider,
      points.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat)));
    return {
      maxLevel, tileErrors,
      normals: provider.hasVertexNormals && mesh.encoding.hasVertexNormals,
      vertices: mesh.vertices.length / mesh.encoding.stride,
      triangles: mesh.indices.length / 3,
      range: [mesh.minimumHeight, mesh.maximumHeight],
      heights: sampled.map((p) => p.height),
      tolerance: provider.getLevelMaximumGeometricError(maxLevel),
    };
  }, [tiles, expect]);
  console.log(`static: layer.json read, deepest level ${r.maxLevel}; one tile there: ${r.vertices} vertices, ` +
    `${r.triangles} triangles, heights ${r.range.map((h) => h.toFixed(0)).join("–")} m, normals ${r.normals}`);
  check(r.triangles > 0, "static: the deepest tile has no triangles");
  check(r.normals, "static: no vertex normals although requested and exported");
  let worst = 0;
  expect.forEach(([lon, lat, want], i) => {
    const got = r.heights[i];
    const off = Math.abs(got - want);
    worst = Math.max(worst, Number.isFinite(off) ? off : Infinity);
    if (!(off <= r.tolerance)) console.error(`  static: ${lon}, ${lat}: ${got} m, source ${want} m`);
  });
  console.log(`static: ${expect.length} heights sampled, worst ${worst.toFixed(1)} m from the source ` +
    `(allowed: the level-${r.maxLevel} geometric error, ${r.tolerance.toFixed(1)} m)`);
  check(worst <= r.tolerance, `static: a sampled height is ${worst.toFixed(1)} m from the source (> ${r.tolerance.toFixed(1)} m)`);
  // The globe draws it: one view from south of the first point, every tile loaded, no error.
  await c.page.evaluate(async ([url, [lon, lat]]) => {
    const terrainProvider = await Cesium.CesiumTerrainProvider.fromUrl(url, { requestVertexNormals: true });
    terrainProvider.errorEvent.addEventListener((e) => console.error(`terrain provider: ${e.message}`));
    const imagery = await Cesium.TileMapServiceImageryProvider.fromUrl(Cesium.buildModuleUrl("Assets/Textures/NaturalEarthII"));
    const viewer = new Cesium.Viewer("c", {
      terrainProvider, baseLayer: new Cesium.ImageryLayer(imagery), baseLayerPicker: false, geocoder: false,
      animation: false, timeline: false, homeButton: false, sceneModePicker: false, navigationHelpButton: false,
      fullscreenButton: false, infoBox: false, selectionIndicator: false });
    viewer.scene.light = new Cesium.DirectionalLight({ direction: new Cesium.Cartesian3(0.6, -0.2, -0.5) });
    viewer.scene.globe.enableLighting = true;
    viewer.camera.setView({ destination: Cesium.Cartesian3.fromDegrees(lon, lat - 0.25, 12000),
      orientation: { heading: 0, pitch: Cesium.Math.toRadians(-25), roll: 0 } });
    window.viewer = viewer;
    window.ztFrames = 0;
    viewer.scene.postRender.addEventListener(() => { window.ztFrames += 1; });
  }, [tiles, expect[0]]);
  await settle(c.page);
  await shoot(c, "static.png");
  const asked = cdn.log.filter((u) => /\.terrain(\?|$)/.test(u));
  console.log(`static: ${asked.length} .terrain request(s), e.g. ${asked[0]}`);
  check(asked.length > 0, "static: no .terrain file was requested");
  for (const t of r.tileErrors) c.problems.push(`terrain provider: ${t}`);
  noProblems(c);
  await c.page.close();
}

// ---- (f) CesiumJS on a static 3D Tiles export ---------------------------------------------

// Heights the two trees give at the same points differ by the quantized-mesh's 16-bit height
// steps (centimetres), the chord of a planar triangle under the curved one (L²/8R: 2 cm for
// 1 km) and the depth picking sampleHeight reads: a metre holds them, and a tile misplaced
// by its transform or the geoid (28 m here) is far outside.
const SAME_SURFACE = 1.0;

async function static3d() {
  check(!!args.static, "static-3dtiles: needs --static, the terrain tree it is compared with");
  const cdn = await host(args["static-3dtiles"]);
  const terrain = await host(args.static);
  const expect = JSON.parse(args.expect || "[]");
  check(expect.length > 0, "static-3dtiles: no --expect points to compare");
  pages["/static-3dtiles.html"] = CESIUM_PAGE;
  const c = await open("static-3dtiles");
  await c.page.goto(`${local}/static-3dtiles.html`);
  const r = await c.page.evaluate(async ([url, terrainUrl, points]) => {
    const at = () => points.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
    const provider = await Cesium.CesiumTerrainProvider.fromUrl(terrainUrl);
    const terrain = (await Cesium.sampleTerrainMostDetailed(provider, at())).map((p) => p.height);
    // No globe: the heights sampled come from the tileset alone.
    const viewer = new Cesium.Viewer("c", {
      globe: false, baseLayer: false, baseLayerPicker: false, geocoder: false, animation: false,
      timeline: false, homeButton: false, sceneModePicker: false, navigationHelpButton: false,
      fullscreenButton: false, infoBox: false, selectionIndicator: false, skyBox: false,
      skyAtmosphere: false });
    const tileErrors = [];
    const tileset = await Cesium.Cesium3DTileset.fromUrl(url);
    tileset.tileFailed.addEventListener((e) => tileErrors.push(`${e.url}: ${e.message}`));
    const contents = [];
    tileset.tileLoad.addEventListener((t) => contents.push(t.content.url));
    viewer.scene.primitives.add(tileset);
    viewer.scene.light = new Cesium.DirectionalLight({ direction: new Cesium.Cartesian3(0.6, -0.2, -0.5) });
    window.viewer = viewer;
    window.ztFrames = 0;
    viewer.scene.postRender.addEventListener(() => { window.ztFrames += 1; });
    const [lon, lat] = points[0];
    viewer.camera.setView({ destination: Cesium.Cartesian3.fromDegrees(lon, lat - 0.25, 12000),
      orientation: { heading: 0, pitch: Cesium.Math.toRadians(-25), roll: 0 } });
    const sampled = (await viewer.scene.sampleHeightMostDetailed(at())).map((p) => p.height);
    return { terrain, sampled, tileErrors, contents, supported: viewer.scene.sampleHeightSupported,
      version: tileset.asset.version };
  }, [`${cdn.origin}/tileset.json`, `${terrain.origin}/`, expect]);
  check(r.supported, "static-3dtiles: this browser cannot sample heights (no depth texture)");
  const leaves = r.contents.filter((u) => u).length;
  console.log(`static-3dtiles: tileset ${r.version} read; ${leaves} tile content(s) loaded while sampling`);
  let worst = 0, worstSource = 0, missing = 0;
  expect.forEach(([lon, lat, want], i) => {
    const got = r.sampled[i], same = r.terrain[i];
    if (!Number.isFinite(got)) { missing += 1; return; }
    const off = Math.abs(got - same);
    worst = Math.max(worst, off);
    worstSource = Math.max(worstSource, Math.abs(got - want));
    if (!(off <= SAME_SURFACE)) console.error(`  static-3dtiles: ${lon}, ${lat}: ${got} m, terrain tree ${same} m`);
  });
  console.log(`static-3dtiles: ${expect.length - missing} heights sampled, worst ${worst.toFixed(2)} m from the ` +
    `terrain tree's (allowed ${SAME_SURFACE} m), ${worstSource.toFixed(1)} m from the source`);
  check(missing === 0, `static-3dtiles: ${missing} point(s) sampled no tile`);
  check(worst <= SAME_SURFACE, `static-3dtiles: a height is ${worst.toFixed(2)} m from the terrain tree's`);
  await settle3d(c.page);
  await shoot(c, "static-3dtiles.png");
  const asked = cdn.log.filter((u) => /\.glb(\?|$)/.test(u));
  console.log(`static-3dtiles: ${asked.length} .glb request(s), e.g. ${asked[0]}`);
  check(asked.length > 0 && asked.every((u) => /\?v=/.test(u)), "static-3dtiles: tiles not requested with the tileset's ?v=");
  for (const t of r.tileErrors) c.problems.push(`tileset: ${t}`);
  noProblems(c);
  await c.page.close();
}

/// As `settle`, for a page whose scene has no globe: its tileset has loaded what it shows.
async function settle3d(page) {
  const from = await page.evaluate(() => window.ztFrames);
  await page.waitForFunction((f) => window.ztFrames >= f + 3, from, { timeout: 60000, polling: 100 });
  await page.waitForFunction(() => window.viewer.scene.primitives.get(0).tilesLoaded, null, { timeout: 60000, polling: 250 });
}

// ---- (e) MapLibre GL JS on a static PNG export ------------------------------------------

// The URL `zerotile export --format png --base-url` was given (tests/clients.rs), so the one
// tiles.json names its tiles under it; the page's transformRequest moves it to the real host.
const PLACEHOLDER = "http://cdn.invalid/rgb";
// docs/api.md: a 512² PNG tile resamples the stored lattice again, so it can differ from the
// source raster by more than T where the terrain is rough (an audit measured up to 8 m).
const RESAMPLING_SLACK = 8;

async function staticPng() {
  const cdn = await host(args["static-png"]);
  // MapLibre takes heights as the tiles hold them, above sea level.
  const expect = JSON.parse(args["expect-png"] || args.expect || "[]");
  check(expect.length > 0, "static-png: no --expect points to compare");
  const info = await describe(args.mercator || "n44m");
  const [lon0, lat0] = expect[0] || [(info.bounds[0] + info.bounds[2]) / 2, (info.bounds[1] + info.bounds[3]) / 2];
  // The terrain source is the TileJSON's URL and nothing else: tile template, zooms, bounds,
  // size and encoding all come from the document.
  const dem = { type: "raster-dem", url: `${PLACEHOLDER}/tiles.json` };
  pages["/static-png.html"] = maplibrePage({
    before: `const from = ${JSON.stringify(PLACEHOLDER)}, to = ${JSON.stringify(cdn.origin)};`,
    options: `
  center: [${lon0}, ${lat0}], zoom: 11.5, pitch: 0,
  // How a page points MapLibre at a tileset that moved: every URL it asks for (tiles.json,
  // then the tiles its template names) passes through here.
  transformRequest: (url) => ({ url: url.startsWith(from + "/") ? to + url.slice(from.length) : url }),
  style: { version: 8, sources: { dem: ${JSON.stringify(dem)} },
    layers: [{ id: "bg", type: "background", paint: { "background-color": "#d8d2c4" } }],
    terrain: { source: "dem", exaggeration: 1 } },`,
    after: `
const idle = () => new Promise((ok) => map.once("idle", ok));
// Heights at [[lon, lat], ...], each read from the deepest zoom's DEM tile: the camera looks
// straight down at zoom deepest + 1.5 (MapLibre's terrain asks for raster-dem tiles one zoom
// above the map's, here the deepest) over each of those tiles in turn, and samples the
// points inside it while it is loaded. queryTerrainElevation answers relative to the
// elevation at the centre of the view (transform.elevation) and scaled by the exaggeration.
window.sample = async (points) => {
  const deepest = map.getSource("dem").maxzoom;
  const groups = new Map();
  points.forEach(([lon, lat], i) => {
    const m = maplibregl.MercatorCoordinate.fromLngLat([lon, lat]);
    const key = [Math.floor(m.x * 2 ** deepest), Math.floor(m.y * 2 ** deepest)].join("/");
    if (!groups.has(key)) groups.set(key, []);
    groups.get(key).push(i);
  });
  const heights = [], zooms = [];
  for (const [key, members] of groups) {
    const [x, y] = key.split("/").map(Number);
    const centre = new maplibregl.MercatorCoordinate((x + 0.5) / 2 ** deepest, (y + 0.5) / 2 ** deepest).toLngLat();
    map.jumpTo({ center: centre, zoom: deepest + 1.5, pitch: 0, bearing: 0 });
    await idle();
    const exaggeration = map.getTerrain().exaggeration;
    for (const i of members) {
      const at = maplibregl.LngLat.convert(points[i]);
      heights[i] = (map.queryTerrainElevation(at) + map.transform.elevation) / exaggeration;
      // The DEM tile that answered, found as queryTerrainElevation finds it (internal API,
      // MapLibre 4.7): it must be the deepest zoom, not a coarser parent standing in.
      const id = map.terrain._getOverscaledTileIDFromLngLatZoom(at, map.transform.tileZoom).tileID;
      const tile = map.terrain.sourceCache.getSourceTile(id, true);
      zooms[i] = tile && tile.dem ? tile.tileID.canonical.z : null;
    }
  }
  return { deepest, views: groups.size, heights, zooms };
};
// Then a view to look at: a hillshade (its own source, as MapLibre asks, from the same
// tiles.json) on the terrain, from south of the first point.
window.overview = async () => {
  map.addSource("hills", ${JSON.stringify(dem)});
  map.addLayer({ id: "hillshade", type: "hillshade", source: "hills", paint: { "hillshade-exaggeration": 0.8 } });
  map.jumpTo({ center: [${lon0}, ${lat0 - 0.04}], zoom: 11, pitch: 60, bearing: 0 });
  await idle();
};
` });
  const c = await open("static-png");
  // A small canvas while sampling: SwiftShader draws it fast, and the heights do not depend
  // on it (the DEM tiles do not).
  await c.page.setViewportSize({ width: 320, height: 240 });
  await c.page.goto(`${local}/static-png.html`);
  // A source that cannot load (no tiles.json, a wrong host) never lets the map go idle: stop
  // at its first error and say what the browser saw.
  await c.page.waitForFunction(() => window.idle === true || window.mapErrors.length > 0, null, { timeout: 90000, polling: 250 });
  if (!(await c.page.evaluate(() => window.idle === true))) {
    await c.page.waitForTimeout(500);
    for (const t of await c.page.evaluate(() => window.mapErrors)) c.problems.push(`map error: ${t}`);
    noProblems(c);
    check(false, "static-png: the map did not load");
    return c.page.close();
  }
  check(await c.page.evaluate(() => !!window.map.getTerrain()), "static-png: terrain is not on");
  const r = await c.page.evaluate((points) => window.sample(points), expect.map(([lon, lat]) => [lon, lat]));
  const allowed = (info.default_thresholds.find((t) => t.zoom === r.deepest) || { threshold: NaN }).threshold;
  let worst = 0;
  expect.forEach(([lon, lat, want], i) => {
    const got = r.heights[i];
    const off = Math.abs(got - want);
    worst = Math.max(worst, Number.isFinite(off) ? off : Infinity);
    if (!(off <= allowed + RESAMPLING_SLACK) || r.zooms[i] !== r.deepest) {
      console.error(`  static-png: ${lon}, ${lat}: ${got} m from a zoom-${r.zooms[i]} tile, source ${want} m`);
    }
  });
  const shallow = r.zooms.filter((z) => z !== r.deepest).length;
  check(shallow === 0, `static-png: ${shallow} height(s) not read from a zoom-${r.deepest} tile`);
  console.log(`static-png: ${expect.length} heights read with queryTerrainElevation from zoom-${r.deepest} tiles in ` +
    `${r.views} views, worst ${worst.toFixed(1)} m from the source (allowed: zoom ${r.deepest}'s threshold ` +
    `${allowed.toFixed(1)} m + ${RESAMPLING_SLACK} m resampling)`);
  check(worst <= allowed + RESAMPLING_SLACK,
    `static-png: a sampled height is ${worst.toFixed(1)} m from the source (> ${(allowed + RESAMPLING_SLACK).toFixed(1)} m)`);

  await c.page.setViewportSize({ width: 960, height: 600 });
  await c.page.evaluate(() => window.overview());
  await shoot(c, "static-png.png");

  // Every request went to the real host (none to the placeholder), and the tiles were asked
  // for by the TileJSON's versioned template.
  const pngs = c.requests.filter((u) => /\/\d+\/\d+\/\d+\.png(\?|$)/.test(u));
  const versioned = pngs.filter((u) => u.startsWith(`${cdn.origin}/`) && /\.png\?v=[0-9a-f]{16}$/.test(u));
  const zooms = [...new Set(pngs.map((u) => Number(new URL(u).pathname.split("/")[1])))].sort((a, b) => a - b);
  console.log(`static-png: tiles.json read ${cdn.log.filter((u) => u.startsWith("/tiles.json")).length} time(s), ` +
    `${pngs.length} tile request(s) (${versioned.length} by its ?v= template; zooms ${zooms.join(",")}), e.g. ${versioned[0]}`);
  check(cdn.log.some((u) => u.startsWith("/tiles.json")), "static-png: tiles.json was not read from the host");
  check(versioned.length > 0, "static-png: no tile was requested through tiles.json's ?v= template");
  check(versioned.length === pngs.length, `static-png: ${pngs.length - versioned.length} tile request(s) not by the template`);
  const strays = c.requests.filter((u) => u.startsWith(PLACEHOLDER));
  check(strays.length === 0, `static-png: ${strays.length} request(s) to the placeholder, e.g. ${strays[0]}`);
  for (const t of await c.page.evaluate(() => window.mapErrors)) c.problems.push(`map error: ${t}`);
  noProblems(c);
  await c.page.close();
}

const clients = { cesium, maplibre, viewer, static: staticExport, "static-png": staticPng, "static-3dtiles": static3d };
try {
  for (const name of only) {
    const t0 = Date.now();
    try {
      await clients[name]();
    } catch (e) {
      check(false, `${name}: ${e.stack || e}`);
    }
    console.log(`${name}: ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  }
} finally {
  await browser.close();
  statics.close();
  for (const h of hosts) h.close();
}
console.log(failures === 0 ? "all clients passed" : `${failures} failure(s)`);
process.exit(failures === 0 ? 0 : 1);
