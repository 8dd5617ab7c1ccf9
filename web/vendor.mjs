// Copies the viewer's front-end files from the pinned npm packages into server/assets/vendor,
// which `zerotile` embeds at compile time (server/src/serve/routes/site.rs). Run after
// `npm ci` whenever package-lock.json changes, and commit the copies: a plain `cargo build`
// never runs npm. Only three.js is embedded (~0.7 MB); CesiumJS and MapLibre are used by the
// client tests straight from node_modules.
import { copyFileSync, mkdirSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

const web = dirname(fileURLToPath(import.meta.url));
const out = join(web, "..", "server", "assets", "vendor");
mkdirSync(out, { recursive: true });
const files = [
  ["three/build/three.module.min.js", "three.module.min.js"],
  ["three/examples/jsm/controls/OrbitControls.js", "OrbitControls.js"],
  ["three/LICENSE", "LICENSE-three.txt"],
];
for (const [from, to] of files) {
  copyFileSync(join(web, "node_modules", from), join(out, to));
  console.log(`vendored ${from} -> server/assets/vendor/${to}`);
}
