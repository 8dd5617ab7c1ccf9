// Scales screenshots down for the README: node tests/e2e/shrink.mjs WIDTH OUT_DIR IN.png…
// (drawn in headless Chromium, so no image tool beyond what the client tests use).
import { readFileSync, writeFileSync } from "node:fs";
import { basename, dirname, join } from "node:path";
import { createRequire } from "node:module";
import { fileURLToPath } from "node:url";

const web = join(dirname(fileURLToPath(import.meta.url)), "..", "..", "web");
const { chromium } = createRequire(join(web, "package.json"))("playwright-core");
const [width, out, ...files] = process.argv.slice(2);
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || "/usr/bin/chromium", args: ["--no-sandbox"] });
const page = await browser.newPage();
for (const f of files) {
  const b64 = await page.evaluate(async ([src, w]) => {
    const img = new Image();
    img.src = `data:image/png;base64,${src}`;
    await img.decode();
    const c = document.createElement("canvas");
    c.width = w;
    c.height = Math.round((img.height * w) / img.width);
    const g = c.getContext("2d");
    g.imageSmoothingQuality = "high";
    g.drawImage(img, 0, 0, c.width, c.height);
    return c.toDataURL("image/png").split(",")[1];
  }, [readFileSync(f).toString("base64"), Number(width)]);
  writeFileSync(join(out, basename(f)), Buffer.from(b64, "base64"));
}
await browser.close();
