// Interoperability: WebWorldWind (npm @nasaworldwind/worldwind) in headless Chromium shows tellus
// serve's Blue Marble (issue #4). The fixture tests/web/worldwind.html and worldwind.min.js are
// served by a small loopback server here, another origin than tellus, so tiles become WebGL
// textures only with tellus's CORS header. WebGL runs on SwiftShader. Two ways in:
//   tiles  a TiledImageLayer with World Wind's LevelRowColumnUrlBuilder on /tiles/bluemarble/...
//   wms    WmsCapabilities + WmsLayer.formLayerConfiguration from GetCapabilities, GetMap per tile
// Each checks: every tile in view arrived (tellus's access log: status 200 for exactly the tiles
// WebWorldWind drew), no console error, nothing asked of other hosts, and the screenshot shows the
// Blue Marble at known places (ocean where there is ocean, land where there is land; a globe
// without imagery is black).
// Usage: node test_worldwind.mjs path/to/tellus path/to/node_modules
import {createReadStream, existsSync, statSync} from 'node:fs';
import {createServer} from 'node:http';
import {dirname, extname, join, normalize, sep} from 'node:path';
import {fileURLToPath} from 'node:url';
import {
  fail, isLand, isOcean, launchChromium, parseArgs, screenshotColours, settledAccessLog,
  startTellus, watchPage, workDir,
} from './harness.mjs';

const {tellus, nodeModules} = parseArgs();
const work = workDir('worldwind');
const {base, accessLog} = await startTellus(tellus, work);

// The fixture's origin: worldwind.html from here, WebWorldWind's files from its npm package.
const here = dirname(fileURLToPath(import.meta.url));
const wwDist = join(nodeModules, '@nasaworldwind', 'worldwind', 'build', 'dist');
if (!existsSync(join(wwDist, 'worldwind.min.js'))) fail(`no worldwind.min.js in ${wwDist}`);
const types = {'.html': 'text/html', '.js': 'text/javascript', '.png': 'image/png'};
const fixture = createServer((req, res) => {
  const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
  const file = path === '/worldwind.html' ? join(here, 'worldwind.html')
                                           : normalize(join(wwDist, path));
  if (!file.startsWith(wwDist + sep) && file !== join(here, 'worldwind.html')) {
    res.writeHead(403).end();
    return;
  }
  if (!existsSync(file) || !statSync(file).isFile()) {
    res.writeHead(404).end();
    return;
  }
  res.writeHead(200, {'Content-Type': types[extname(file)] ?? 'application/octet-stream'});
  createReadStream(file).pipe(res);
});
await new Promise((resolve) => fixture.listen(0, '127.0.0.1', resolve));
const fixtureBase = `http://127.0.0.1:${fixture.address().port}`;

// [lat, lon] in view from the fixture's camera (15 N, 35 W, the whole hemisphere).
const places = [
  {name: 'central Atlantic', at: [15, -35], want: isOcean},
  {name: 'South Atlantic', at: [-25, -20], want: isOcean},
  {name: 'Sahara', at: [22, 10], want: isLand},
  {name: 'Amazon', at: [-8, -60], want: isLand},
  {name: 'Labrador Sea', at: [57, -52], want: isOcean},
];

const browser = await launchChromium(nodeModules);
try {
  for (const mode of ['tiles', 'wms']) {
    const context = await browser.newContext({viewport: {width: 800, height: 800}});
    const seen = await watchPage(context, [base, fixtureBase]);
    const page = await context.newPage();
    const before = (await settledAccessLog(accessLog, () => true)).length;
    await page.goto(`${fixtureBase}/worldwind.html?tellus=${encodeURIComponent(base)}&mode=${mode}`,
                    {waitUntil: 'load'});
    await page
      .waitForFunction(() => window.wwTest.ready || window.wwTest.error, null, {timeout: 60000})
      .catch(() => fail(`${mode}: WebWorldWind did not get its tiles: ` +
                        `${JSON.stringify(seen.responses.slice(-10))}, errors ${seen.errors}`));
    const state = await page.evaluate(() => ({error: window.wwTest.error, tiles: window.wwTest.tiles}));
    if (state.error) fail(`${mode}: ${state.error}`);
    // Two frames after the last texture, then the picture.
    await page.evaluate(() => new Promise((resolve) => {
      window.wwTest.wwd.redraw();
      requestAnimationFrame(() => requestAnimationFrame(resolve));
    }));
    const pixels = await page.evaluate(
      (ats) => ats.map(([lat, lon]) => window.wwTest.pixelOf(lat, lon)), places.map((p) => p.at));
    const png = await page.screenshot({path: join(work, `worldwind-${mode}.png`)});
    const colours = await screenshotColours(context, png, pixels.map((p) => p ?? [0, 0]));
    places.forEach((p, i) => {
      if (!pixels[i]) fail(`${mode}: ${p.name} is not in view`);
      if (!p.want(colours[i]))
        fail(`${mode}: ${p.name} (${p.at}) at pixel ${pixels[i]} has colour ${colours[i]}, not ` +
             `${p.want === isLand ? 'land' : 'ocean'}`);
    });

    // tellus answered every tile WebWorldWind drew, with status 200.
    const log = (await settledAccessLog(accessLog, (e) => e.length - before >= state.tiles.length))
      .slice(before);
    const tileLines = log.filter((e) => mode === 'tiles' ? e.protocol === 'static'
                                                         : /REQUEST=GetMap/i.test(e.target ?? ''));
    if (tileLines.length < state.tiles.length)
      fail(`${mode}: ${state.tiles.length} tiles drawn, ${tileLines.length} in the access log`);
    const bad = log.filter((e) => e.status !== '200');
    if (bad.length) fail(`${mode}: answers other than 200: ${JSON.stringify(bad)}`);
    if (mode === 'tiles') {
      for (const t of state.tiles) {
        const [level, row, col] = t.split('/');
        const target = `/tiles/bluemarble/${level}/${row}/${row}_${col}.jpg`;
        if (!tileLines.some((e) => e.target === target))
          fail(`tiles: WebWorldWind drew ${t} but tellus never served ${target}`);
      }
    } else if (!log.some((e) => /REQUEST=GetCapabilities/i.test(e.target ?? ''))) {
      fail('wms: the capabilities were not read from tellus');
    }

    if (seen.outside.length) fail(`${mode}: requests to other hosts: ${seen.outside}`);
    if (seen.failed.length) fail(`${mode}: failed requests: ${seen.failed.join('; ')}`);
    if (seen.errors.length) fail(`${mode}: console errors: ${seen.errors.join('; ')}`);
    console.log(`worldwind ${mode}: ${state.tiles.length} tiles drawn (levels ` +
                `${[...new Set(state.tiles.map((t) => t.split('/')[0]))].join(',')}), ` +
                `${tileLines.length} answered 200, ${places.length} places right`);
    await context.close();
  }
} finally {
  await browser.close();
}
process.exit(0); // tellus serve and the fixture server keep the event loop alive; exit ends them
