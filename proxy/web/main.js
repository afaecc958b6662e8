// The page at / of `tellus serve`: the server's layers (layers.json) on an OpenLayers map in
// EPSG:4326, read from the static World Wind tile layout tiles/<layer>/<level>/<row>/<row>_<col>.<ext>.
// Bundled with OpenLayers by esbuild at build time (proxy/CMakeLists.txt) and embedded in the binary.
import 'ol/ol.css';
import './style.css';
import OlMap from 'ol/Map.js';
import View from 'ol/View.js';
import TileLayer from 'ol/layer/Tile.js';
import TileImage from 'ol/source/TileImage.js';
import TileGrid from 'ol/tilegrid/TileGrid.js';
import MousePosition from 'ol/control/MousePosition.js';
import ScaleLine from 'ol/control/ScaleLine.js';
import {defaults as defaultControls} from 'ol/control/defaults.js';
import {createStringXY} from 'ol/coordinate.js';

const WORLD = [-180, -90, 180, 90];

// What the page did, for people and for the headless test (tests/web/test_page.mjs).
const state = {layer: null, loaded: 0, failed: 0, error: null};
window.tellusPage = state;

function showStatus() {
  const el = document.getElementById('status');
  el.textContent = state.error
    ? state.error
    : `${state.layer ?? 'no layer'}: ${state.loaded} tiles loaded` +
      (state.failed ? `, ${state.failed} failed` : '');
}

// A World Wind level set as an OpenLayers tile grid. Origin in the south-west corner (-180, -90),
// where World Wind counts from: OpenLayers counts tile rows from the origin *downwards*
// (y = (originY - latitude) / tile height), so every row above the origin is negative and World
// Wind's row (0 at -90, growing northwards) is -y - 1.
function tileSource(layer) {
  const resolutions = [];
  for (let level = 0; level < layer.levels; ++level)
    resolutions.push(layer.levelZeroDelta / layer.tileWidth / 2 ** level);
  const tileGrid = new TileGrid({
    extent: WORLD,
    origin: [-180, -90],
    resolutions,
    tileSize: [layer.tileWidth, layer.tileHeight],
    minZoom: layer.firstLevel,
  });
  const path = `tiles/${encodeURIComponent(layer.name)}/`;
  const source = new TileImage({
    projection: 'EPSG:4326',
    tileGrid,
    wrapX: false,
    transition: 0,
    tileUrlFunction: ([level, col, y]) => {
      const row = -y - 1;
      return `${path}${level}/${row}/${row}_${col}.${layer.extension}`;
    },
  });
  source.on('tileloadend', () => {
    ++state.loaded;
    showStatus();
  });
  source.on('tileloaderror', () => {
    ++state.failed;
    showStatus();
  });
  return source;
}

function layerLabel(layer, checked) {
  const label = document.createElement('label');
  const input = document.createElement('input');
  input.type = 'radio';
  input.name = 'layer';
  input.value = layer.name;
  input.checked = checked;
  const name = document.createElement('span');
  name.className = 'name';
  name.textContent = ` ${layer.name}`;
  const meta = document.createElement('div');
  meta.className = 'meta';
  meta.textContent = `${layer.title} (${layer.format}, ${layer.levels} levels of ` +
    `${layer.tileWidth} px, level 0: ${layer.levelZeroDelta} deg)`;
  label.append(input, name, meta);
  return label;
}

function start(info) {
  document.getElementById('title').textContent = info.title;
  document.title = info.title;
  // The page's globe is the Earth: layers on other bodies (issue 26) are not offered.
  const imagery = info.layers.filter((l) => !l.elevation && (l.body ?? 'earth') === 'earth');
  const elevation = info.layers.filter((l) => l.elevation);

  const list = document.getElementById('elevation');
  list.replaceChildren();
  for (const l of elevation) {
    const li = document.createElement('li');
    li.textContent = `${l.name}: ${l.title} (${l.format})`;
    list.append(li);
  }
  if (!elevation.length) list.innerHTML = '<li class="note">none</li>';

  const wanted = new URLSearchParams(location.hash.slice(1)).get('layer');
  const first = imagery.find((l) => l.name === wanted) ?? imagery[0];
  const form = document.getElementById('layers');
  form.replaceChildren();
  if (!first) {
    form.innerHTML = '<p class="note">no imagery layers</p>';
    return;
  }

  const layers = new Map();
  for (const l of imagery) {
    const s = l.sector;
    layers.set(
      l.name,
      new TileLayer({
        source: tileSource(l),
        extent: [s.west, s.south, s.east, s.north],
        visible: l === first,
      }),
    );
    form.append(layerLabel(l, l === first));
  }
  state.layer = first.name;

  const map = new OlMap({
    target: 'map',
    layers: [...layers.values()],
    controls: defaultControls().extend([
      new ScaleLine(),
      new MousePosition({coordinateFormat: createStringXY(3), projection: 'EPSG:4326'}),
    ]),
    view: new View({projection: 'EPSG:4326', center: [0, 0], extent: WORLD, showFullExtent: true}),
  });
  map.getView().fit(WORLD, {size: map.getSize()});
  state.map = map;

  form.addEventListener('change', (e) => {
    state.layer = e.target.value;
    for (const [name, layer] of layers) layer.setVisible(name === state.layer);
    history.replaceState(null, '', `#layer=${encodeURIComponent(state.layer)}`);
    showStatus();
  });
  showStatus();
}

fetch('layers.json')
  .then((r) => {
    if (!r.ok) throw new Error(`layers.json: HTTP ${r.status}`);
    return r.json();
  })
  .then(start)
  .catch((e) => {
    console.error('tellus page:', e);
    state.error = String(e);
    showStatus();
  });
