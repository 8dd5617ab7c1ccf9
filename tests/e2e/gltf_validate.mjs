// Validates GLB files with the Khronos glTF-Validator (npm `gltf-validator`, pinned in
// web/package.json; `npm ci --prefix web --ignore-scripts`), for tests/gltf.rs.
//
//   node tests/e2e/gltf_validate.mjs [--strict] FILE.glb...
//
// Prints one JSON line per file: {file, numErrors, numWarnings, numInfos, numHints,
// messages: [{code, severity, message, pointer?, offset?}]} (severity as the validator
// counts it: 0 error, 1 warning, 2 info, 3 hint). Exits 1 when any file has an error (with
// --strict, also a warning), 2 on bad usage or a file the validator could not read at all.
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import { basename, dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

const require = createRequire(
  join(dirname(fileURLToPath(import.meta.url)), "../../web/package.json"),
);
const validator = require("gltf-validator");

const args = process.argv.slice(2);
const strict = args.includes("--strict");
const files = args.filter((a) => a !== "--strict");
if (files.length === 0 || files.some((f) => f.startsWith("--"))) {
  console.error("usage: node gltf_validate.mjs [--strict] FILE.glb...");
  process.exit(2);
}

let failed = false;
for (const file of files) {
  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
      uri: basename(file),
      maxIssues: 0, // no limit
    });
  } catch (e) {
    console.log(JSON.stringify({ file, fatal: String(e) }));
    process.exit(2);
  }
  const issues = report.issues;
  const line = {
    file,
    numErrors: issues.numErrors,
    numWarnings: issues.numWarnings,
    numInfos: issues.numInfos,
    numHints: issues.numHints,
    truncated: issues.truncated,
    messages: issues.messages.map(({ code, severity, message, pointer, offset }) => ({
      code,
      severity,
      message,
      ...(pointer === undefined ? {} : { pointer }),
      ...(offset === undefined ? {} : { offset }),
    })),
  };
  console.log(JSON.stringify(line));
  if (issues.numErrors > 0 || (strict && issues.numWarnings > 0)) {
    failed = true;
  }
}
process.exit(failed ? 1 : 0);
