// What the browser tests share (tests/web/test_*.mjs): a seeded `tellus serve` on a loopback port
// with its access log, Debian's Chromium driven by playwright-core (no browser download), a guard
// that lets the browser reach loopback only, and colours read back from a screenshot.
import {spawn, spawnSync} from 'node:child_process';
import {createReadStream, existsSync, mkdtempSync, readFileSync, rmSync, statSync} from 'node:fs';
import {createServer} from 'node:http';
import {createRequire} from 'node:module';
import {tmpdir} from 'node:os';
import {extname, join, normalize, resolve as absolute, sep} from 'node:path';

export function fail(message) {
  console.error(`FAIL: ${message}`);
  process.exit(1);
}

/** argv: <tellus> <node_modules of tests/web/package.json> */
export function parseArgs() {
  const [tellus, nodeModules] = process.argv.slice(2);
  if (!tellus || !nodeModules) fail('usage: node <test>.mjs path/to/tellus path/to/node_modules');
  return {tellus: absolute(tellus), nodeModules: absolute(nodeModules)};
}

/** A work directory under $TMPDIR, removed at exit unless KEEP_WORK is set. */
export function workDir(name) {
  const dir = mkdtempSync(join(process.env.TMPDIR || tmpdir(), `tellus-${name}.`));
  process.on('exit', () => {
    if (process.env.KEEP_WORK) console.log(`work directory kept: ${dir}`);
    else rmSync(dir, {recursive: true, force: true});
  });
  return dir;
}

/**
 * `tellus seed --cache DIR --levels 0-1` (of every layer, or of `seedLayers`: seeding etopo takes
 * most of the time), then `tellus serve` on 127.0.0.1:0 with an access log; resolves with its base
 * URL once it printed "listening on". Killed at exit.
 */
export async function startTellus(tellus, work, extraServeArgs = [], seedLayers = []) {
  const cache = join(work, 'cache');
  const seed = spawnSync(
    tellus,
    ['seed', '--cache', cache, '--levels', '0-1', ...seedLayers.flatMap((l) => ['--layer', l])],
    {encoding: 'utf8'});
  if (seed.status !== 0) fail(`tellus seed: ${seed.stderr}${seed.stdout}`);
  const accessLog = join(work, 'access.log');
  const server = spawn(
    tellus,
    ['serve', '--cache', cache, '--listen', '127.0.0.1:0', '--access-log', accessLog,
     ...extraServeArgs],
    {stdio: ['ignore', 'pipe', 'pipe']});
  process.on('exit', () => server.kill());
  let output = '';
  const base = await new Promise((resolve) => {
    const timer = setTimeout(() => fail(`tellus serve did not start: ${output}`), 15000);
    const look = (chunk) => {
      output += chunk;
      const m = output.match(/listening on (?:http:\/\/)?(127\.0\.0\.1:\d+)/);
      if (m) {
        clearTimeout(timer);
        resolve(`http://${m[1]}`);
      }
    };
    server.stdout.on('data', look);
    server.stderr.on('data', look);
    server.on('exit', (code) => fail(`tellus serve exited (${code}): ${output}`));
  });
  return {base, cache, accessLog};
}

/** The access log's lines as objects (logfmt: key=value or key="quoted value"). */
export function readAccessLog(file) {
  const entries = [];
  for (const line of readFileSync(file, 'utf8').split('\n')) {
    if (!line.trim()) continue;
    const e = {};
    for (const m of line.matchAll(/(\w+)=("((?:[^"\\]|\\.)*)"|\S*)/g))
      e[m[1]] = m[3] !== undefined ? m[3].replace(/\\(.)/g, '$1') : m[2];
    entries.push(e);
  }
  return entries;
}

/** The access log once it has settled (the server writes a line when it answers). */
export async function settledAccessLog(file, wantFn, timeoutMs = 5000) {
  const until = Date.now() + timeoutMs;
  for (;;) {
    const entries = readAccessLog(file);
    if (wantFn(entries) || Date.now() > until) return entries;
    await new Promise((r) => setTimeout(r, 100));
  }
}

/**
 * Debian's Chromium, headless, through playwright-core. WebGL runs on SwiftShader (no GPU in CI).
 * CHROMIUM overrides the executable. Not sandboxed: the tests run as root in CI containers and the
 * browser only ever sees loopback pages of the test itself.
 */
export async function launchChromium(nodeModules) {
  const require = createRequire(join(nodeModules, 'package.json'));
  const {chromium} = require('playwright-core');
  const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
  // Chromium's own temporary files (its singleton socket among them) go into a directory of ours
  // that is removed at exit: a failing test exits at once and the killed browser would leave them
  // in $TMPDIR. Under /tmp, as a socket path must be shorter than 108 bytes.
  const tmp = mkdtempSync('/tmp/tellus-chromium.');
  process.on('exit', () => rmSync(tmp, {recursive: true, force: true}));
  return chromium.launch({
    executablePath,
    env: {...process.env, TMPDIR: tmp},
    headless: true,
    chromiumSandbox: false,
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
           '--no-first-run', '--disable-background-networking', '--disable-component-update',
           '--disable-default-apps', '--disable-sync', '--no-pings'],
  });
}

/**
 * Records what a page does: console errors and warnings, uncaught exceptions, failed requests and
 * every response; any request that is not to one of `allowedOrigins` (loopback) or a data: URL is
 * aborted and recorded as outside.
 */
export async function watchPage(context, allowedOrigins) {
  const seen = {errors: [], warnings: [], failed: [], outside: [], responses: []};
  await context.route('**/*', (route) => {
    const url = route.request().url();
    if (url.startsWith('data:') || allowedOrigins.some((o) => url.startsWith(`${o}/`)))
      return route.continue();
    seen.outside.push(url);
    return route.abort('blockedbyclient');
  });
  context.on('page', (page) => {
    page.on('console', (msg) => {
      if (msg.type() === 'error') seen.errors.push(`console: ${msg.text()}`);
      else if (msg.type() === 'warning') seen.warnings.push(msg.text());
    });
    page.on('pageerror', (e) => seen.errors.push(`exception: ${e.message}`));
  });
  context.on('requestfailed', (req) => {
    if (!seen.outside.includes(req.url()))
      seen.failed.push(`${req.url()}: ${req.failure()?.errorText}`);
  });
  context.on('response', (res) => seen.responses.push({url: res.url(), status: res.status()}));
  return seen;
}

/**
 * Colours at CSS pixel positions of a page screenshot: the PNG is decoded by the browser itself
 * (drawn into a 2D canvas of a blank page), so no image library is needed here.
 */
export async function screenshotColours(context, png, points) {
  const page = await context.newPage();
  try {
    return await page.evaluate(
      async ({b64, pts}) => {
        const img = new Image();
        img.src = `data:image/png;base64,${b64}`;
        await img.decode();
        const canvas = document.createElement('canvas');
        canvas.width = img.width;
        canvas.height = img.height;
        const g = canvas.getContext('2d', {willReadFrequently: true});
        g.drawImage(img, 0, 0);
        return pts.map(([x, y]) => {
          const d = g.getImageData(Math.round(x), Math.round(y), 1, 1).data;
          return [d[0], d[1], d[2]];
        });
      },
      {b64: png.toString('base64'), pts: points});
  } finally {
    await page.close();
  }
}

/** Blue Marble ocean (deep ocean is as dark as (2, 6, 19)): blue above red and green. */
export const isOcean = ([r, g, b]) => b >= 15 && b > r + 10 && b > g;
/** Blue Marble land (desert, steppe, rain forest as dark as (21, 34, 8)): red or green above blue.
 * Black, what a globe or map without imagery shows, is neither land nor ocean. */
export const isLand = ([r, g, b]) => r + g >= 30 && Math.max(r, g) > b + 5;

/**
 * A loopback server for a test's own files, another origin than tellus (so tiles become WebGL or
 * canvas pixels only with tellus's CORS header): `files` maps a URL path to a file or to a string
 * of HTML, `dirs` a URL prefix ending in '/' to a directory whose files it serves. Resolves with
 * its base URL; closed at exit.
 */
export async function serveFixture({files = {}, dirs = {}}) {
  const types = {'.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css',
                 '.json': 'application/json', '.png': 'image/png', '.jpg': 'image/jpeg',
                 '.wasm': 'application/wasm'};
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    let file = files[path];
    if (typeof file === 'object') {
      res.writeHead(200, {'Content-Type': 'text/html'}).end(file.html);
      return;
    }
    for (const [prefix, dir] of Object.entries(dirs)) {
      if (file || !path.startsWith(prefix)) continue;
      const inDir = normalize(join(dir, path.slice(prefix.length)));
      if (inDir.startsWith(normalize(dir) + sep)) file = inDir;
    }
    if (!file || !existsSync(file) || !statSync(file).isFile()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, {'Content-Type': types[extname(file)] ?? 'application/octet-stream'});
    createReadStream(file).pipe(res);
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  process.on('exit', () => server.close());
  return `http://127.0.0.1:${server.address().port}`;
}

/**
 * The colours of the cached tiles at [lat, lon] places: World Wind level `level` of `layer` (36
 * degree level zero, `size` px) read from tellus's static path /tiles/ (the cached files), decoded
 * by the browser and averaged over a window of `radius` pixels around each place (within its tile).
 */
export async function cachedColours(context, base, {layer, level, size, places, radius = 4}) {
  const page = await context.newPage();
  try {
    return await page.evaluate(
      async ({base, layer, level, size, places, radius}) => {
        const delta = 36 / 2 ** level;
        const out = [];
        for (const [lat, lon] of places) {
          const row = Math.floor((lat + 90) / delta);
          const col = Math.floor((lon + 180) / delta);
          const img = new Image();
          img.crossOrigin = 'anonymous';
          img.src = `${base}/tiles/${layer}/${level}/${row}/${row}_${col}.jpg`;
          await img.decode();
          const canvas = document.createElement('canvas');
          canvas.width = canvas.height = size;
          const g = canvas.getContext('2d', {willReadFrequently: true});
          g.drawImage(img, 0, 0);
          const x = Math.round(((lon + 180) / delta - col) * size);
          const y = Math.round((row + 1 - (lat + 90) / delta) * size);
          const d = g.getImageData(x - radius, y - radius, 2 * radius + 1, 2 * radius + 1).data;
          const sum = [0, 0, 0];
          let n = 0; // the pixels inside the tile (outside, getImageData gives transparent black)
          for (let i = 0; i < d.length; i += 4) {
            if (d[i + 3] === 0) continue;
            for (let c = 0; c < 3; ++c) sum[c] += d[i + c];
            ++n;
          }
          out.push(sum.map((s) => Math.round(s / n)));
        }
        return out;
      },
      {base, layer, level, size, places, radius});
  } finally {
    await page.close();
  }
}

/** Colours alike within `tolerance` in each channel. */
export const near = (a, b, tolerance) => a.every((v, i) => Math.abs(v - b[i]) <= tolerance);
