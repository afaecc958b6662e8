// Cross-origin requests from a browser (issue 21, "HTTP"): a page served from another origin (another
// loopback port) fetches a tile and a WMS GetMap from `tellus serve` with headers a browser does
// not send on its own (Authorization, X-Requested-With, as Cesium's Resource and many web maps
// do). Chromium sends a CORS preflight (OPTIONS) first; the real request only follows when the
// preflight answers 204 with Access-Control-Allow-Origin/-Methods/-Headers. Also through the real
// binary: requests the server refuses (another method, a raw space in the target) are in its
// access log like any other request.
// Usage: node test_cors.mjs path/to/tellus path/to/node_modules
import {createServer} from 'node:http';
import {connect} from 'node:net';

import {fail, launchChromium, parseArgs, settledAccessLog, startTellus, workDir} from './harness.mjs';

const {tellus, nodeModules} = parseArgs();
const work = workDir('web-cors');
const {base, accessLog} = await startTellus(tellus, work);

// The other origin: a page that asks tellus for bytes with a non-safelisted header.
const page = `<!doctype html><html><head><meta charset="utf-8"><title>cors</title></head>
<body><script>
window.fetchBytes = async (url, headers) => {
  try {
    const r = await fetch(url, {headers});
    const bytes = (await r.arrayBuffer()).byteLength;
    return {status: r.status, type: r.headers.get('content-type'), bytes};
  } catch (e) {
    return {error: String(e)};
  }
};
</script></body></html>`;
const other = createServer((req, res) => {
  res.writeHead(200, {'Content-Type': 'text/html; charset=utf-8'});
  res.end(page);
});
await new Promise((resolve) => other.listen(0, '127.0.0.1', resolve));
const origin = `http://127.0.0.1:${other.address().port}`;
if (origin === base) fail('the page must come from another origin');

/** Sends raw bytes to tellus and resolves with the status line of its answer. */
function raw(bytes) {
  const {hostname, port} = new URL(base);
  return new Promise((resolve) => {
    const socket = connect({host: hostname, port: Number(port)}, () => socket.write(bytes));
    let got = '';
    socket.on('data', (d) => { got += d.toString('latin1'); });
    socket.on('close', () => resolve(got.split('\r\n')[0]));
    socket.on('error', () => resolve(got.split('\r\n')[0] ?? ''));
    socket.setTimeout(5000, () => socket.destroy());
  });
}

const browser = await launchChromium(nodeModules);
try {
  const context = await browser.newContext();
  // Not harness.watchPage: with request interception on, Playwright answers CORS preflights
  // itself and the server would never see them. The page loads nothing but what it is asked to.
  const failed = [];
  context.on('requestfailed', (req) => failed.push(`${req.url()}: ${req.failure()?.errorText}`));
  const tab = await context.newPage();
  const loaded = await tab.goto(`${origin}/`, {waitUntil: 'load'});
  if (loaded.status() !== 200) fail(`the other origin's page answered ${loaded.status()}`);

  const tile = `${base}/tiles/bluemarble/0/0/0_0.jpg`;
  const map = `${base}/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=bluemarble&STYLES=` +
              '&CRS=CRS:84&BBOX=-180,-90,-144,-54&WIDTH=512&HEIGHT=512&FORMAT=image/jpeg';
  const asked = [
    {url: tile, headers: {Authorization: 'Bearer not-a-secret'}},
    {url: map, headers: {'X-Requested-With': 'XMLHttpRequest'}},
  ];
  for (const {url, headers} of asked) {
    const got = await tab.evaluate(([u, h]) => window.fetchBytes(u, h), [url, headers]);
    if (got.error || got.status !== 200 || got.type !== 'image/jpeg' || got.bytes < 1000)
      fail(`${origin} fetching ${url} with ${JSON.stringify(headers)}: ${JSON.stringify(got)}`);
  }

  // What went over the wire: a preflight answered 204, then the GET answered 200, for each.
  const log = await settledAccessLog(
    accessLog, (e) => e.filter((x) => x.method === 'GET' && x.status === '200').length >= 2);
  for (const {url} of asked) {
    const target = url.slice(base.length);
    const preflight = log.find((e) => e.method === 'OPTIONS' && e.target === target);
    if (!preflight || preflight.status !== '204')
      fail(`no OPTIONS 204 for ${target} in the access log: ${JSON.stringify(log)}`);
    if (!log.some((e) => e.method === 'GET' && e.target === target && e.status === '200'))
      fail(`no GET 200 for ${target} in the access log: ${JSON.stringify(log)}`);
  }
  if (failed.length) fail(`failed requests: ${failed.join('; ')}`);

  // Refused requests are answered and logged like any other.
  const refused = [
    {bytes: 'DELETE /wms HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n', status: '405',
     method: 'DELETE', target: '/wms'},
    {bytes: 'GET /wwtile?T=bluemarble a b HTTP/1.1\r\nHost: a\r\n\r\n', status: '400',
     method: 'GET', target: '/wwtile?T=bluemarble a b'},
  ];
  for (const r of refused) {
    const line = await raw(r.bytes);
    if (!line.startsWith(`HTTP/1.1 ${r.status}`))
      fail(`${JSON.stringify(r.bytes)} answered '${line}', not ${r.status}`);
  }
  const after = await settledAccessLog(
    accessLog, (e) => refused.every((r) => e.some((x) => x.status === r.status)));
  for (const r of refused) {
    if (!after.some((e) => e.method === r.method && e.target === r.target && e.status === r.status))
      fail(`no access-log line for the refused ${r.method} ${r.target}: ${JSON.stringify(after)}`);
  }
  console.log(`cors: a tile and a GetMap fetched from ${origin} with Authorization and ` +
              'X-Requested-With (preflights 204); refused requests logged');
} finally {
  await browser.close();
  other.close();
}
process.exit(0); // tellus serve, a child with pipes, keeps the event loop alive; exit kills it
