// Builds the page at / of `tellus serve` (run by proxy/CMakeLists.txt when an input changes):
//   node build.mjs <out dir> <node_modules dir>
// writes <out>/index.html (naming the bundle with its hash), app.js (main.js with OpenLayers, minified), app.css (ol.css and
// style.css) and licenses.txt (the licence of every npm package in the bundle, which their BSD/MIT
// terms ask binaries to carry), each also gzip-compressed (.gz), for proxy/src/web/WebPage.cpp to embed. The
// node_modules come from `npm ci` in the build tree, so the source tree stays clean.
import {createHash} from 'node:crypto';
import {createRequire} from 'node:module';
import {mkdirSync, readdirSync, readFileSync, writeFileSync} from 'node:fs';
import {dirname, join, relative, resolve, sep} from 'node:path';
import {fileURLToPath} from 'node:url';
import {gzipSync, constants} from 'node:zlib';

const [outDir, nodeModules] = process.argv.slice(2).map((p) => resolve(p));
if (!outDir || !nodeModules) {
  console.error('usage: node build.mjs <out dir> <node_modules dir>');
  process.exit(2);
}
const here = dirname(fileURLToPath(import.meta.url));
const esbuild = createRequire(join(nodeModules, 'package.json'))('esbuild');

mkdirSync(outDir, {recursive: true});
const result = await esbuild.build({
  entryPoints: {app: join(here, 'main.js')},
  bundle: true,
  minify: true,
  format: 'iife',
  target: ['es2020'],
  outdir: outDir,
  nodePaths: [nodeModules],
  legalComments: 'none',
  logLevel: 'warning',
  metafile: true,
});

// The packages whose code is in the bundle, from esbuild's list of inputs.
const packages = new Set();
for (const input of Object.keys(result.metafile.inputs)) {
  const rel = relative(nodeModules, resolve(input)).split(sep);
  if (rel[0] === '..' || rel.length < 2) continue; // our own files
  packages.add(rel[0].startsWith('@') ? `${rel[0]}/${rel[1]}` : rel[0]);
}
let licenses = 'Third-party code in app.js and app.css of the tellus page (bundled from npm):\n';
for (const name of [...packages].sort()) {
  const dir = join(nodeModules, name);
  const meta = JSON.parse(readFileSync(join(dir, 'package.json'), 'utf8'));
  const file = readdirSync(dir).find((f) => /^(licen[cs]e|copying)/i.test(f));
  licenses += `\n==== ${name} ${meta.version} (${meta.license ?? 'see below'})\n\n`;
  licenses += file ? readFileSync(join(dir, file), 'utf8').trim() + '\n' : '(no licence file)\n';
}
writeFileSync(join(outDir, 'licenses.txt'), licenses);
// index.html names the bundle with its content hash, so that browsers may keep app.js and app.css
// (WebPage.cpp serves them with max-age) and still see a new build at once.
const version = (name) =>
  createHash('sha256').update(readFileSync(join(outDir, name))).digest('hex').slice(0, 16);
let html = readFileSync(join(here, 'index.html'), 'utf8');
for (const name of ['app.js', 'app.css']) {
  const ref = `"${name}"`;
  if (!html.includes(ref)) throw new Error(`index.html does not name ${ref}`);
  html = html.replace(ref, `"${name}?v=${version(name)}"`);
}
writeFileSync(join(outDir, 'index.html'), html);
for (const name of ['index.html', 'app.js', 'app.css', 'licenses.txt']) {
  const bytes = readFileSync(join(outDir, name));
  writeFileSync(join(outDir, `${name}.gz`), gzipSync(bytes, {level: constants.Z_BEST_COMPRESSION}));
}
