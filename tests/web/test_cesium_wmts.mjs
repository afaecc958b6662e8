// Interoperability: CesiumJS (npm cesium, unmodified) in headless Chromium shows tellus serve's
// WMTS (issue 25) through WebMapTileServiceImageryProvider, as a user would set it up:
//   worldwind  the layer's own set WorldWind_bluemarble (the cached tiles byte for byte) through
//              the capabilities' RESTful template, with a GeographicTilingScheme of 10 x 5
//              level-zero tiles (the set's matrix 0; Cesium's default 2 x 1 would not line up)
//   mercator   GoogleMapsCompatible through the KVP binding, Cesium's default WebMercatorTilingScheme
// The fixture tests/web/cesium_wmts.html and Cesium's Build/Cesium are served by a loopback server
// of the test (another origin: tiles become WebGL textures only with tellus's CORS header). No Ion
// token, no terrain, no network but loopback; WebGL on SwiftShader. Each checks: Cesium asked
// /wmts for tiles of that set and tellus answered each with 200 (its access log), no tile error,
// no console error, nothing asked of other hosts, and the screenshot at known places (ocean, land)
// has the colour of the cached level-1 tiles there.
// Usage: node test_cesium_wmts.mjs path/to/tellus path/to/node_modules
import {existsSync} from 'node:fs';
import {dirname, join} from 'node:path';
import {fileURLToPath} from 'node:url';
import {
  cachedColours, fail, isLand, isOcean, launchChromium, near, parseArgs, screenshotColours,
  serveFixture, settledAccessLog, startTellus, watchPage, workDir,
} from './harness.mjs';

const {tellus, nodeModules} = parseArgs();
const work = workDir('cesium-wmts');
const {base, accessLog} = await startTellus(tellus, work, [], ['bluemarble']);

const here = dirname(fileURLToPath(import.meta.url));
const cesiumBuild = join(nodeModules, 'cesium', 'Build', 'Cesium');
if (!existsSync(join(cesiumBuild, 'Cesium.js'))) fail(`no Cesium.js in ${cesiumBuild}`);
const fixtureBase = await serveFixture({
  files: {'/cesium_wmts.html': join(here, 'cesium_wmts.html')},
  dirs: {'/cesium/': cesiumBuild},
});

// [lat, lon] in view from the fixture's camera (15 N, 35 W, 9000 km up).
const places = [
  {name: 'central Atlantic', at: [15, -35], want: isOcean},
  {name: 'South Atlantic', at: [-25, -20], want: isOcean},
  {name: 'Sahara', at: [22, 10], want: isLand},
  {name: 'Amazon', at: [-8, -60], want: isLand},
  {name: 'Labrador Sea', at: [57, -52], want: isOcean},
];
// Rendered against cached colours: the globe samples another level, filtered (seen: 10 apart).
const tolerance = 20;
const sets = {worldwind: 'WorldWind_bluemarble', mercator: 'GoogleMapsCompatible'};

const browser = await launchChromium(nodeModules);
try {
  const tileContext = await browser.newContext();
  const cached = await cachedColours(tileContext, base, {
    layer: 'bluemarble', level: 1, size: 512, places: places.map((p) => p.at)});
  await tileContext.close();
  for (const mode of ['worldwind', 'mercator']) {
    const context = await browser.newContext({viewport: {width: 640, height: 640}});
    const seen = await watchPage(context, [base, fixtureBase]);
    const page = await context.newPage();
    const started = Date.now();
    const before = (await settledAccessLog(accessLog, () => true)).length;
    await page.goto(`${fixtureBase}/cesium_wmts.html?tellus=${encodeURIComponent(base)}&mode=${mode}`,
                    {waitUntil: 'load'});
    await page
      .waitForFunction(() => window.cesiumTest.ready || window.cesiumTest.error, null,
                       {timeout: 60000})
      .catch(() => fail(`${mode}: Cesium did not load its tiles: ` +
                        `${JSON.stringify(seen.responses.slice(-10))}, errors ${seen.errors}`));
    const loadedMs = Date.now() - started;
    const state = await page.evaluate(() => ({error: window.cesiumTest.error,
                                              tileErrors: window.cesiumTest.tileErrors}));
    if (state.error) fail(`${mode}: ${state.error}`);
    if (state.tileErrors.length) fail(`${mode}: tile errors: ${state.tileErrors.join('; ')}`);

    const pixels = await page.evaluate(
      (ats) => ats.map(([lat, lon]) => window.cesiumTest.pixelOf(lat, lon)), places.map((p) => p.at));
    const png = await page.screenshot({path: join(work, `cesium-${mode}.png`)});
    const colours = await screenshotColours(context, png, pixels.map((p) => p ?? [0, 0]));
    places.forEach((p, i) => {
      if (!pixels[i]) fail(`${mode}: ${p.name} is not in view`);
      const kind = p.want === isLand ? 'land' : 'ocean';
      if (!p.want(colours[i]) || !near(colours[i], cached[i], tolerance))
        fail(`${mode}: ${p.name} (${p.at}) at pixel ${pixels[i].map(Math.round)} has colour ` +
             `${colours[i]}, the cached tile ${cached[i]} (${kind})`);
    });

    // Cesium's tile requests went to /wmts for this set and tellus answered each with 200.
    const asked = seen.responses.filter((r) => new URL(r.url).pathname.startsWith('/wmts'));
    const log = (await settledAccessLog(accessLog, (e) => e.length - before >= asked.length))
      .slice(before);
    const tiles = log.filter((e) => e.protocol === 'wmts' &&
                                    (e.target ?? '').includes(sets[mode]));
    if (tiles.length === 0 || tiles.length < asked.length)
      fail(`${mode}: ${asked.length} requests to /wmts, ${tiles.length} tiles of ${sets[mode]} ` +
           `in the access log: ${JSON.stringify(log.slice(0, 5))}`);
    const bad = log.filter((e) => e.status !== '200');
    if (bad.length) fail(`${mode}: answers other than 200: ${JSON.stringify(bad.slice(0, 5))}`);
    if (mode === 'mercator' && !tiles.every((e) => /REQUEST=GetTile/i.test(e.target)))
      fail(`mercator: not the KVP binding: ${tiles[0].target}`);

    if (seen.outside.length) fail(`${mode}: requests to other hosts: ${seen.outside}`);
    if (seen.failed.length) fail(`${mode}: failed requests: ${seen.failed.join('; ')}`);
    if (seen.errors.length) fail(`${mode}: console errors: ${seen.errors.join('; ')}`);
    console.log(`cesium ${mode}: ${tiles.length} tiles of ${sets[mode]} answered 200 ` +
                `(loaded in ${loadedMs} ms), ${places.length} places right (rendered ${JSON.stringify(colours)}, cached ` +
                `${JSON.stringify(cached)})`);
    await context.close();
  }
} finally {
  await browser.close();
}
process.exit(0); // tellus serve and the fixture server keep the event loop alive; exit ends them
