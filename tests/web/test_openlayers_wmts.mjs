// Interoperability: OpenLayers (npm ol, the version of proxy/web, unmodified) in headless Chromium
// shows tellus serve's WMTS (issue 25) with optionsFromCapabilities on tellus's capabilities:
//   crs84     WorldCRS84Quad (composed from the cached tiles) in an EPSG:4326 view
//   mercator  GoogleMapsCompatible (composed, EPSG:3857) in an EPSG:3857 view
// The fixture tests/web/openlayers_wmts.js is bundled with OpenLayers by esbuild (as proxy/web's
// page is) into the work directory and served with a page by a loopback server of the test
// (another origin than tellus). Each checks: OpenLayers read the capabilities and asked /wmts for
// tiles of that set, tellus answered each with 200 (its access log), no tile failed, no console
// error, nothing asked of other hosts, and the screenshot at known places (ocean, land) has the
// colour of the cached level-1 tiles there.
// Usage: node test_openlayers_wmts.mjs path/to/tellus path/to/node_modules
import {createRequire} from 'node:module';
import {dirname, join} from 'node:path';
import {fileURLToPath} from 'node:url';
import {
  cachedColours, fail, isLand, isOcean, launchChromium, near, parseArgs, screenshotColours,
  serveFixture, settledAccessLog, startTellus, watchPage, workDir,
} from './harness.mjs';

const {tellus, nodeModules} = parseArgs();
const work = workDir('openlayers-wmts');
const {base, accessLog} = await startTellus(tellus, work, [], ['bluemarble']);

const here = dirname(fileURLToPath(import.meta.url));
const esbuild = createRequire(join(nodeModules, 'package.json'))('esbuild');
const bundle = join(work, 'openlayers_wmts.js');
await esbuild.build({
  entryPoints: [join(here, 'openlayers_wmts.js')],
  bundle: true,
  format: 'iife',
  target: ['es2020'],
  outfile: bundle,
  nodePaths: [nodeModules],
  logLevel: 'warning',
});
const html = '<!doctype html><html lang="en"><head><meta charset="utf-8"><title>OpenLayers on ' +
  'tellus\'s WMTS</title><link rel="icon" href="data:,"><style>html, body, #map { margin: 0; ' +
  'width: 100%; height: 100%; background: #000; }</style></head><body><div id="map"></div>' +
  '<script src="openlayers_wmts.js"></script></body></html>';
const fixtureBase = await serveFixture({
  files: {'/openlayers_wmts.html': {html}, '/openlayers_wmts.js': bundle},
});

// [lat, lon] in view of the whole world between 75 S and 75 N.
const places = [
  {name: 'central Atlantic', at: [15, -35], want: isOcean},
  {name: 'South Atlantic', at: [-25, -20], want: isOcean},
  {name: 'Sahara', at: [22, 10], want: isLand},
  {name: 'Amazon', at: [-8, -60], want: isLand},
  {name: 'Labrador Sea', at: [57, -52], want: isOcean},
  {name: 'Australia', at: [-25, 133], want: isLand},
  {name: 'central Pacific', at: [0, -150], want: isOcean},
];
// Rendered against cached colours: the map shows composed tiles of another size, resampled.
const tolerance = 20;
const sets = {crs84: 'WorldCRS84Quad', mercator: 'GoogleMapsCompatible'};

const browser = await launchChromium(nodeModules);
try {
  const tileContext = await browser.newContext();
  const cached = await cachedColours(tileContext, base, {
    layer: 'bluemarble', level: 1, size: 512, places: places.map((p) => p.at), radius: 8});
  await tileContext.close();
  for (const mode of ['crs84', 'mercator']) {
    const context = await browser.newContext({viewport: {width: 800, height: 400}});
    const seen = await watchPage(context, [base, fixtureBase]);
    const page = await context.newPage();
    const before = (await settledAccessLog(accessLog, () => true)).length;
    const started = Date.now();
    await page.goto(
      `${fixtureBase}/openlayers_wmts.html?tellus=${encodeURIComponent(base)}&mode=${mode}`,
      {waitUntil: 'load'});
    await page
      .waitForFunction(() => window.olTest.ready || window.olTest.error, null, {timeout: 30000})
      .catch(() => fail(`${mode}: OpenLayers did not get its tiles: ` +
                        `${JSON.stringify(seen.responses.slice(-10))}, errors ${seen.errors}`));
    const loadedMs = Date.now() - started;
    const state = await page.evaluate(() => {
      const {error, loaded, failed, requestEncoding, projection} = window.olTest;
      return {error, loaded, failed, requestEncoding, projection};
    });
    if (state.error) fail(`${mode}: ${state.error}`);
    if (state.failed) fail(`${mode}: ${state.failed} tiles failed to load`);

    const pixels = await page.evaluate(
      (ats) => ats.map(([lat, lon]) => window.olTest.pixelOf(lat, lon)), places.map((p) => p.at));
    const png = await page.screenshot({path: join(work, `openlayers-${mode}.png`)});
    const colours = await screenshotColours(context, png, pixels);
    places.forEach((p, i) => {
      const kind = p.want === isLand ? 'land' : 'ocean';
      if (!p.want(colours[i]) || !near(colours[i], cached[i], tolerance))
        fail(`${mode}: ${p.name} (${p.at}) at pixel ${pixels[i].map(Math.round)} has colour ` +
             `${colours[i]}, the cached tile ${cached[i]} (${kind})`);
    });

    // The capabilities and every tile came from tellus's /wmts, each answered with 200.
    const log = (await settledAccessLog(accessLog, (e) => e.length - before >= 1 + state.loaded))
      .slice(before);
    if (!log.some((e) => /REQUEST=GetCapabilities/i.test(e.target ?? '')))
      fail(`${mode}: the capabilities were not read from tellus`);
    const tiles = log.filter((e) => e.protocol === 'wmts' && (e.target ?? '').includes(sets[mode]));
    if (tiles.length < state.loaded)
      fail(`${mode}: ${state.loaded} tiles loaded, ${tiles.length} tiles of ${sets[mode]} in the ` +
           `access log: ${JSON.stringify(log.slice(0, 5))}`);
    const bad = log.filter((e) => e.status !== '200');
    if (bad.length) fail(`${mode}: answers other than 200: ${JSON.stringify(bad.slice(0, 5))}`);

    if (seen.outside.length) fail(`${mode}: requests to other hosts: ${seen.outside}`);
    if (seen.failed.length) fail(`${mode}: failed requests: ${seen.failed.join('; ')}`);
    if (seen.errors.length) fail(`${mode}: console errors: ${seen.errors.join('; ')}`);
    console.log(`openlayers ${mode}: ${state.projection}, ${state.requestEncoding}, ` +
                `${tiles.length} tiles of ${sets[mode]} answered 200 (loaded in ${loadedMs} ms), ` +
                `${places.length} places right (rendered ${JSON.stringify(colours)}, cached ` +
                `${JSON.stringify(cached)})`);
    await context.close();
  }
} finally {
  await browser.close();
}
process.exit(0); // tellus serve and the fixture server keep the event loop alive; exit ends them
