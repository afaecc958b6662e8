// The page at / of `tellus serve` in headless Chromium (issue #4):
//   - it loads with no console error, no uncaught exception, no failed request, and nothing from
//     outside the server (every request not to the server is blocked and fails the test);
//   - it lists the layers of layers.json (bluemarble to draw, etopo as elevation), and the
//     plain-text index it links to is at /index.txt;
//   - the map's level-0 tiles arrive from the static path /tiles/bluemarble/0/<row>/<row>_<col>.jpg
//     with status 200, in the page's network events and in the server's access log (cache=HIT);
//   - the map shows the right places: land where there is land and ocean where there is ocean,
//     which fails if rows were counted from the wrong pole (OpenLayers' y is negative upwards from
//     the origin at -90, World Wind's row positive) or columns were off.
// Usage: node test_page.mjs path/to/tellus path/to/node_modules
import {
  fail, isLand, isOcean, launchChromium, parseArgs, screenshotColours, settledAccessLog,
  startTellus, watchPage, workDir,
} from './harness.mjs';

const {tellus, nodeModules} = parseArgs();
const work = workDir('web-page');
const {base, accessLog} = await startTellus(tellus, work);

const browser = await launchChromium(nodeModules);
try {
  const context = await browser.newContext({viewport: {width: 1400, height: 800}});
  const seen = await watchPage(context, [base]);
  const page = await context.newPage();
  const response = await page.goto(`${base}/`, {waitUntil: 'load'});
  if (response.status() !== 200) fail(`GET / answered ${response.status()}`);
  if (!response.headers()['content-type']?.startsWith('text/html'))
    fail(`GET / is ${response.headers()['content-type']}, not HTML`);

  // The world at level 0 is 10 x 5 tiles; wait for them and for the map to be drawn.
  await page
    .waitForFunction(() => window.tellusPage?.loaded + window.tellusPage?.failed >= 50, null,
                     {timeout: 30000})
    .catch(() => fail(`tiles did not arrive: ${JSON.stringify(
        seen.responses.filter((r) => r.url.includes('/tiles/')))}`));
  await page.evaluate(
    () => new Promise((resolve) => {
      const map = window.tellusPage.map;
      map.once('rendercomplete', resolve);
      map.render();
    }));
  const state = await page.evaluate(() => ({
    layer: window.tellusPage.layer,
    loaded: window.tellusPage.loaded,
    failed: window.tellusPage.failed,
    error: window.tellusPage.error,
    radios: [...document.querySelectorAll('#layers input[type=radio]')].map((i) => i.value),
    elevation: document.getElementById('elevation').textContent,
  }));
  if (state.error) fail(`the page says: ${state.error}`);
  if (state.layer !== 'bluemarble') fail(`the map shows '${state.layer}', not bluemarble`);
  // The embedded default's imagery: the Blue Marble and the night lights (issue 23).
  if (JSON.stringify(state.radios) !== '["bluemarble","nightlights"]')
    fail(`layer switcher offers ${JSON.stringify(state.radios)}, not the two imagery layers`);
  if (!state.elevation.includes('etopo')) fail(`elevation list: '${state.elevation}'`);
  if (state.failed !== 0) fail(`${state.failed} tiles failed to load`);

  // The tiles came from the static World Wind path, each with status 200.
  const tileRe = /\/tiles\/bluemarble\/(\d+)\/(\d+)\/(\d+)_(\d+)\.jpg$/;
  const tiles = seen.responses.filter((r) => tileRe.test(new URL(r.url).pathname));
  if (tiles.length < 50) fail(`only ${tiles.length} tile responses: ${JSON.stringify(tiles)}`);
  const bad = tiles.filter((r) => r.status !== 200);
  if (bad.length) fail(`tile responses not 200: ${JSON.stringify(bad)}`);
  for (const {url} of tiles) {
    const [, level, row, row2, col] = new URL(url).pathname.match(tileRe).map(Number);
    if (level !== 0 || row !== row2 || row > 4 || col > 9) fail(`odd tile request ${url}`);
  }
  const log = await settledAccessLog(
    accessLog, (e) => e.filter((x) => x.target?.startsWith('/tiles/')).length >= tiles.length);
  const served = log.filter((e) => e.target?.startsWith('/tiles/bluemarble/0/'));
  if (served.length < 50 || served.some((e) => e.status !== '200' || e.cache !== 'HIT'))
    fail(`access log: ${JSON.stringify(served)}`);
  for (const path of ['/', '/layers.json']) {
    if (!log.some((e) => e.target === path && e.status === '200'))
      fail(`access log has no 200 for ${path}`);
  }
  const assets = log.filter((e) => /^\/app\.(js|css)\?v=[0-9a-f]{16}$/.test(e.target ?? ''));
  if (assets.length !== 2 || assets.some((e) => e.status !== '200'))
    fail(`bundle requests: ${JSON.stringify(assets)}`);

  // Places on the screenshot: (lon, lat) -> page pixel through the map itself.
  const places = [
    {name: 'Kansas', lonLat: [-100, 40], want: isLand},
    {name: 'South Pacific', lonLat: [-100, -40], want: isOcean},
    {name: 'Sahara', lonLat: [10, 23], want: isLand},
    {name: 'Indian Ocean', lonLat: [80, -20], want: isOcean},
    {name: 'Central Atlantic', lonLat: [-35, 20], want: isOcean},
    {name: 'Australia', lonLat: [134, -25], want: isLand},
  ];
  const pixels = await page.evaluate((lonLats) => {
    const map = window.tellusPage.map;
    const box = map.getTargetElement().getBoundingClientRect();
    return lonLats.map((ll) => {
      const [x, y] = map.getPixelFromCoordinate(ll);
      return [box.left + x, box.top + y];
    });
  }, places.map((p) => p.lonLat));
  const png = await page.screenshot({path: `${work}/page.png`});
  const colours = await screenshotColours(context, png, pixels);
  places.forEach((p, i) => {
    if (!p.want(colours[i]))
      fail(`${p.name} (${p.lonLat}) at pixel ${pixels[i]} has colour ${colours[i]}, which is not ` +
           `${p.want === isLand ? 'land' : 'ocean'}: are rows or columns misplaced?`);
  });

  // The endpoints in plain text, linked from the page's header.
  const index = await context.request.get(`${base}/index.txt`);
  const text = await index.text();
  if (index.status() !== 200 || !text.includes(`WMS:        ${base}/wms?`) ||
      !text.includes(`Map page:   ${base}/`))
    fail(`/index.txt: ${index.status()} ${text}`);

  if (seen.outside.length) fail(`the page asked for things outside the server: ${seen.outside}`);
  if (seen.failed.length) fail(`failed requests: ${seen.failed.join('; ')}`);
  if (seen.errors.length) fail(`console errors: ${seen.errors.join('; ')}`);
  console.log(`page: ${tiles.length} tiles with status 200, ${places.length} places right, ` +
              `no console errors`);
} finally {
  await browser.close();
}
process.exit(0); // tellus serve, a child with pipes, keeps the event loop alive; exit kills it
