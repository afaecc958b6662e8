// Test fixture of tests/web/test_openlayers_wmts.mjs, bundled there by esbuild with OpenLayers (npm
// ol, the version of proxy/web): a map of tellus serve's WMTS as the OpenLayers examples make one,
// with optionsFromCapabilities on tellus's capabilities and nothing set by hand but the layer and
// the tile matrix set.
//   ?tellus=<base URL>&mode=crs84     WorldCRS84Quad in an EPSG:4326 view
//   ?tellus=<base URL>&mode=mercator  GoogleMapsCompatible in an EPSG:3857 view
// window.olTest says when every tile in view is drawn (ready) or what went wrong (error).
import Map from 'ol/Map.js';
import View from 'ol/View.js';
import WMTSCapabilities from 'ol/format/WMTSCapabilities.js';
import TileLayer from 'ol/layer/Tile.js';
import {transform, transformExtent} from 'ol/proj.js';
import WMTS, {optionsFromCapabilities} from 'ol/source/WMTS.js';

const params = new URLSearchParams(location.search);
const tellus = params.get('tellus');
const mode = params.get('mode');
const test = {ready: false, error: null, loaded: 0, failed: 0, pending: 0};
window.olTest = test;

async function main() {
  const sets = {crs84: ['WorldCRS84Quad', 'EPSG:4326'], mercator: ['GoogleMapsCompatible', 'EPSG:3857']};
  if (!sets[mode]) throw new Error(`mode must be crs84 or mercator, not ${mode}`);
  const [matrixSet, projection] = sets[mode];
  const r = await fetch(`${tellus}/wmts?SERVICE=WMTS&REQUEST=GetCapabilities`);
  if (!r.ok) throw new Error(`GetCapabilities: HTTP ${r.status}`);
  const caps = new WMTSCapabilities().read(await r.text());
  const options = optionsFromCapabilities(caps, {layer: 'bluemarble', matrixSet});
  if (!options) throw new Error(`optionsFromCapabilities found no bluemarble in ${matrixSet}`);
  test.requestEncoding = options.requestEncoding;
  test.projection = options.projection.getCode();
  const source = new WMTS({...options, crossOrigin: 'anonymous'});
  source.on('tileloadstart', () => ++test.pending);
  source.on('tileloadend', () => { --test.pending; ++test.loaded; });
  source.on('tileloaderror', () => { --test.pending; ++test.failed; });
  const map = new Map({
    target: 'map',
    controls: [],
    layers: [new TileLayer({source})],
    view: new View({projection}),
  });
  map.getView().fit(transformExtent([-180, -75, 180, 75], 'EPSG:4326', projection));
  map.on('rendercomplete', () => {
    if (test.loaded + test.failed > 0 && test.pending === 0) test.ready = true;
  });
  test.pixelOf = (lat, lon) => map.getPixelFromCoordinate(transform([lon, lat], 'EPSG:4326', projection));
}

main().catch((e) => { test.error = String(e); });
