// deck.gl's terrain loaders (loaders.gl 4.3, in Node) against a running `zerotile serve`:
//   quantized-mesh  QuantizedMeshLoader on a geodetic dataset's .terrain tiles: the same
//                   triangles as the server's own .json mesh of each tile (vertices within the
//                   format's 16-bit quantisation), and heights at --expect (the source's own,
//                   [[lon, lat, metres], ...]) within T + the lattice's resampling slack
//   terrain-rgb     TerrainLoader (what deck.gl's TerrainLayer uses) on a mercator dataset's
//   terrarium       PNG tiles, with the elevation decoder each encoding documents: heights at
//                   the --expect points within T + slack of the tile's stored lattice (its
//                   `.json?threshold=0` mesh; the mercator lattice is coarser than the source)
// Exit status 0 = all passed.
//
//   node tests/e2e/loaders.mjs --base http://127.0.0.1:8080 --geodetic n44g --mercator n44m \
//        --zoom 10 --threshold 4 --expect '[[-71.3,44.27,1905]]'

import { readFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

// The packages are pinned in web/ (as the browser tests' are) and loaded by their ES module
// entry: @loaders.gl/polyfills installs Node's image parser only there, not in its CommonJS
// build.
const modules = join(dirname(fileURLToPath(import.meta.url)), "..", "..", "web", "node_modules");
const load = (name) => {
  const dir = join(modules, name);
  const entry = JSON.parse(readFileSync(join(dir, "package.json"), "utf8")).exports["."].import;
  return import(pathToFileURL(join(dir, entry)).href);
};
await load("@loaders.gl/polyfills");
const { parse, registerLoaders } = await load("@loaders.gl/core");
const { ImageLoader } = await load("@loaders.gl/images");
const { QuantizedMeshLoader, TerrainLoader } = await load("@loaders.gl/terrain");
registerLoaders([ImageLoader]);

const args = Object.fromEntries(
  process.argv.slice(2).reduce((acc, a, i, all) => (a.startsWith("--") ? [...acc, [a.slice(2), all[i + 1]]] : acc), []),
);
const base = (args.base || "http://127.0.0.1:8080").replace(/\/$/, "");
const zoom = Number(args.zoom || 10);
const threshold = Number(args.threshold || 4);
// Resampling between rasters that do not share a lattice (the source onto a zoom's tiles,
// a tile's lattice onto its 512² PNG) moves rough ground by more than T: up to 8 m here, the
// allowance tests/e2e/clients.mjs gives MapLibre too.
const RESAMPLING_SLACK = 8;
const expect = JSON.parse(args.expect || "[]");
let failed = false;
const check = (ok, what) => {
  if (!ok) {
    failed = true;
    console.error(`FAIL ${what}`);
  }
};
check(expect.length > 0, "no --expect points");

async function fetchOk(path) {
  const r = await fetch(base + path);
  if (!r.ok) throw new Error(`${path}: ${r.status} ${await r.text()}`);
  return r;
}

// The height at (x, y) of a mesh {positions: xyz…, indices}, interpolated in the first
// triangle that holds the point; null when none does.
function heightAt({ positions: p, indices }, x, y) {
  for (let t = 0; t < indices.length; t += 3) {
    const [a, b, c] = [indices[t] * 3, indices[t + 1] * 3, indices[t + 2] * 3];
    const d = (p[b + 1] - p[c + 1]) * (p[a] - p[c]) + (p[c] - p[b]) * (p[a + 1] - p[c + 1]);
    if (d === 0) continue;
    const l1 = ((p[b + 1] - p[c + 1]) * (x - p[c]) + (p[c] - p[b]) * (y - p[c + 1])) / d;
    const l2 = ((p[c + 1] - p[a + 1]) * (x - p[c]) + (p[a] - p[c]) * (y - p[c + 1])) / d;
    const l3 = 1 - l1 - l2;
    if (l1 >= -1e-9 && l2 >= -1e-9 && l3 >= -1e-9) return l1 * p[a + 2] + l2 * p[b + 2] + l3 * p[c + 2];
  }
  return null;
}

// Reads every --expect point from the client's mesh of the tile `tileOf` puts it in (each
// tile loaded once by `load(tile)` into {mesh, reference}) and compares it with
// `reference(point, tile)`, which must be within `allowed` metres.
async function sample(label, { tileOf, project, load, reference, allowed, against }) {
  const tiles = new Map();
  let worst = 0;
  for (const point of expect) {
    const [lon, lat] = point;
    const tile = tileOf(lon, lat);
    const key = tile.join("/");
    if (!tiles.has(key)) tiles.set(key, await load(tile));
    const loaded = tiles.get(key);
    const [x, y] = project(lon, lat);
    const got = heightAt(loaded.mesh, x, y);
    const want = reference(point, loaded, x, y);
    check(got !== null && want !== null, `${label}: ${lon}, ${lat} lies in no triangle of tile ${key}`);
    if (got === null || want === null) continue;
    const off = Math.abs(got - want);
    worst = Math.max(worst, off);
    if (off > allowed) console.error(`  ${label}: ${lon}, ${lat}: ${got.toFixed(1)} m, ${against} ${want.toFixed(1)} m`);
  }
  console.log(`${label}: ${expect.length} heights from ${tiles.size} zoom-${zoom} tiles at T = ${threshold} m, ` +
    `worst ${worst.toFixed(2)} m from the ${against} (allowed ${allowed} m)`);
  check(worst <= allowed, `${label}: a height is ${worst.toFixed(2)} m from the ${against}`);
}

// Geodetic (Cesium's TMS grid: 2 × 1 root tiles of 180°, rows from the south).
if (args.geodetic) {
  const size = 180 / 2 ** zoom;
  let compared = 0;
  await sample("quantized-mesh", {
    tileOf: (lon, lat) => [zoom, Math.floor((lon + 180) / size), Math.floor((lat + 90) / size)],
    project: (lon, lat) => [lon, lat],
    load: async ([z, x, y]) => {
      const bounds = [x * size - 180, y * size - 90, (x + 1) * size - 180, (y + 1) * size - 90];
      const path = `/v1/datasets/${args.geodetic}/tiles/${z}/${x}/${y}`;
      const bytes = await (await fetchOk(`${path}.terrain?threshold=${threshold}`)).arrayBuffer();
      const qm = await parse(bytes, QuantizedMeshLoader, { "quantized-mesh": { bounds }, worker: false });
      const mesh = { positions: qm.attributes.POSITION.value, indices: qm.indices.value };
      // The server's own mesh of the tile (degrees, metres): the same vertices in the same
      // order, each within half a quantisation step (u, v: the tile / 32767; h: the relief
      // / 32767), and the same triangles.
      const own = await (await fetchOk(`${path}.json?threshold=${threshold}`)).json();
      const n = mesh.positions.length;
      check(own.positions.length === n, `quantized-mesh ${path}: ${n / 3} vertices, the server's mesh ${own.positions.length / 3}`);
      check(
        own.indices.length === mesh.indices.length && own.indices.every((v, i) => v === mesh.indices[i]),
        `quantized-mesh ${path}: the triangles differ from the server's mesh`,
      );
      let [lo, hi] = [Infinity, -Infinity];
      for (let i = 2; i < own.positions.length; i += 3) [lo, hi] = [Math.min(lo, own.positions[i]), Math.max(hi, own.positions[i])];
      const step = [size / 32767, size / 32767, Math.max(hi - lo, 1e-9) / 32767];
      // POSITION is a Float32Array: compare with the server's value as a float32, allowing
      // half a step and one float32 spacing at that value (3.8e-6° at 72° W, most of a
      // zoom-10 step).
      const ulp = (v) => (v === 0 ? 0 : 2 ** (Math.floor(Math.log2(Math.abs(v))) - 23));
      let worst = 0;
      for (let i = 0; i < Math.min(n, own.positions.length); i++) {
        const off = Math.abs(mesh.positions[i] - Math.fround(own.positions[i]));
        worst = Math.max(worst, off / (step[i % 3] / 2 + ulp(own.positions[i])));
      }
      check(worst <= 1, `quantized-mesh ${path}: a vertex is ${worst.toFixed(2)}× its allowance from the server's mesh`);
      compared += 1;
      return { mesh };
    },
    reference: ([, , want]) => want,
    allowed: threshold + RESAMPLING_SLACK,
    against: "source",
  });
  console.log(`quantized-mesh: ${compared} tiles decode to the server's own meshes`);
}

// Mercator (XYZ, rows from the north), bounds in EPSG:3857 metres as deck.gl passes them.
if (args.mercator) {
  const R = 6378137;
  const world = 2 * Math.PI * R;
  const size = world / 2 ** zoom;
  // The PNG side the dataset's TileJSON announces (the server's default, 512).
  const png = (await (await fetchOk(`/v1/datasets/${args.mercator}/tiles.json`)).json()).tileSize;
  const px = size / png;
  const project = (lon, lat) => [(lon * Math.PI * R) / 180, R * Math.log(Math.tan(Math.PI / 4 + (lat * Math.PI) / 360))];
  // The tile whose mesh holds the point: meshes sit half a pixel east and south of their
  // tiles' boxes (below), so a point by a box's west or north edge is in its neighbour's.
  const tileOf = (lon, lat) => {
    const [mx, my] = project(lon, lat);
    return [zoom, Math.floor((mx - px / 2 + world / 2) / size), Math.floor((world / 2 - my - px / 2) / size)];
  };
  const decoders = {
    "terrain-rgb": { rScaler: 6553.6, gScaler: 25.6, bScaler: 0.1, offset: -10000 },
    terrarium: { rScaler: 256, gScaler: 1, bScaler: 1 / 256, offset: -32768 },
  };
  for (const [encoding, elevationDecoder] of Object.entries(decoders)) {
    await sample(encoding, {
      tileOf,
      project,
      load: async ([z, x, y]) => {
        const path = `/v1/datasets/${args.mercator}/tiles/${z}/${x}/${y}`;
        const bytes = await (await fetchOk(`${path}.png?threshold=${threshold}&encoding=${encoding}`)).arrayBuffer();
        // TerrainLoader puts pixel (i, j) at the bounds' corner + (i, -j) pixels, where the
        // PNG's pixel centres lie half a pixel in (docs/api.md; MapLibre reads them so):
        // bounds moved half a pixel east and south register the two. With the tile's own box,
        // as deck.gl's TerrainLayer passes it, the heights land half a pixel north-west.
        const [west, north] = [x * size - world / 2 + px / 2, world / 2 - y * size - px / 2];
        const bounds = [west, north - size, west + size, north];
        const t = await parse(bytes, TerrainLoader, { terrain: { elevationDecoder, bounds, meshMaxError: 0.25 }, worker: false });
        const mesh = { positions: t.attributes.POSITION.value, indices: t.indices.value };
        // The tile's stored lattice, every sample a vertex (EPSG:3857 metres, metres).
        const lattice = await (await fetchOk(`${path}.json?threshold=0`)).json();
        return { mesh, lattice };
      },
      reference: (_, { lattice }, x, y) => heightAt(lattice, x, y),
      allowed: threshold + RESAMPLING_SLACK,
      against: "stored lattice",
    });
  }
}

process.exit(failed ? 1 : 0);
