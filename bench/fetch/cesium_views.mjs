// bench/fetch (issue 29): CesiumJS (npm cesium 1.145, tests/web's pinned packages) in headless
// Chromium (SwiftShader) on each view of VIEWS_JSON, each in a fresh browser context (new cache),
// against the synthetic WMS of bench/fetch/upstream.py: /reset before a view, /stats after it.
// Writes OUT/cesium-<name>.png and prints one JSON line a view:
//   {"name", "requests", "texels", "seconds", "settled"} (settled: every tile in view was drawn
//   before CESIUM_LIMIT_S seconds, default 300; else what it had fetched by then).
// Usage: node cesium_views.mjs NODE_MODULES UPSTREAM_URL VIEWS_JSON OUT
// Env WMS_URL and WMS_LAYER: the WMS CesiumJS asks (default UPSTREAM_URL/wms, layer synthetic),
// e.g. `tellus serve` in front of the upstream (run.py's PROXY=1); the counts stay the upstream's.
import {existsSync, readFileSync} from 'node:fs';
import {dirname, join} from 'node:path';
import {fileURLToPath} from 'node:url';
import {launchChromium, serveFixture} from '../../tests/web/harness.mjs';

const [nodeModules, upstream, viewsFile, out] = process.argv.slice(2);
const cesiumBuild = join(nodeModules, 'cesium', 'Build', 'Cesium');
if (!existsSync(join(cesiumBuild, 'Cesium.js'))) throw new Error(`no Cesium.js in ${cesiumBuild}`);
const here = dirname(fileURLToPath(import.meta.url));
const fixture = await serveFixture({
  files: {'/cesium_fetch.html': join(here, 'cesium_fetch.html')},
  dirs: {'/cesium/': cesiumBuild},
});
const views = JSON.parse(readFileSync(viewsFile, 'utf8'));
const limitMs = Number(process.env.CESIUM_LIMIT_S ?? 300) * 1000;
const browser = await launchChromium(nodeModules);
try {
  for (const v of views) {
    const context = await browser.newContext({viewport: {width: v.width, height: v.height}});
    const page = await context.newPage();
    await fetch(`${upstream}/reset`);
    const started = Date.now();
    const q = new URLSearchParams({wms: process.env.WMS_URL ?? `${upstream}/wms`,
                                   layers: process.env.WMS_LAYER ?? 'synthetic', lat: v.lat,
                                   lon: v.lon, alt: v.alt, heading: v.heading, tilt: v.tilt});
    await page.goto(`${fixture}/cesium_fetch.html?${q}`, {waitUntil: 'load'});
    // A view that never settles (tiles still loading after the limit) is reported as it stands.
    const settled = await page
      .waitForFunction(() => window.fetchBench.ready, null, {timeout: limitMs})
      .then(() => true, () => false);
    const seconds = (Date.now() - started) / 1000;
    const stats = await (await fetch(`${upstream}/stats`)).json();
    const errors = await page.evaluate(() => window.fetchBench.tileErrors);
    await page.screenshot({path: join(out, `cesium-${v.name}.png`)});
    console.log(JSON.stringify({name: v.name, ...stats, seconds, settled,
                                tileErrors: errors.length}));
    await context.close();
  }
} finally {
  await browser.close();
}
process.exit(0);
