// The independent judge: the same glTF files, camera and punctual lights rendered by Myriad (raw
// linear `final`, exposure 1, ambient 0, black background) and by three.js (WebGL 2 through
// SwiftShader in Debian's headless Chromium, NoToneMapping, a float render target read back),
// compared under the metric of metric.mjs and the tolerances below (docs/ARCHITECTURE.md,
// section 9, says how they were measured).
//
// three.js renders each case twice: `spec` (its punctual BRDF patched to the glTF 2.0 spec's
// Appendix B, which Myriad implements; page/three_render.mjs lists the patches) is held to a tight
// tolerance, and `stock` (three.js as shipped: height-correlated Smith visibility, multiple-
// scattering compensation, specular anti-aliasing, smoothstep spot cones) to a looser one that
// covers those model differences as measured.
//
// Usage: node judge_test.mjs <myriad-server> <output dir> [--pending] [--save] [--case NAME]...
//   --pending  also render the cases waiting for a Myriad feature (reported, never failing)
//   --save     write the PNGs of every case, not only of the failing ones
//   --save-raw also write the float images (Myriad's final rgb and depth, three.js's rgba)
// Exit 0 pass, 1 fail, 77 skip (no Chromium at /usr/bin/chromium).

import {existsSync, mkdirSync, readFileSync, writeFileSync} from 'node:fs';
import {dirname, extname, join, resolve} from 'node:path';
import {fileURLToPath} from 'node:url';
import {startServer} from '../browser/server_process.mjs';
import {CASES} from './cases.mjs';
import {unsupportedGlb, writePng} from './fixtures.mjs';
import {compare, pictures, verdict} from './metric.mjs';

const HERE = dirname(fileURLToPath(import.meta.url));
const CHROMIUM = '/usr/bin/chromium';
const ORIGIN = 'http://judge.test';
const REQUEST_MS = 60000;  // one Myriad request (a model load, a frame) on lavapipe with validation

// Measured on lavapipe vs SwiftShader (docs/ARCHITECTURE.md section 9 has the numbers); `coverage`
// is the share of covered pixels that may be geometry in one image only, away from silhouettes.
export const TOLERANCE = {mean: 0.01, p95: 0.025, bias: 0.01, coverage: 0.001};

// Deliberate errors that the tolerance must reject, each on its case, in every run.
const SENSITIVITY = [
  ['spheres-sun', 'every light 4% brighter', {light: 1.04}],
  ['spheres-sun', 'the sun turned 3 degrees', {sunDegrees: 3}],
  ['spheres-sun', 'roughness 20% higher', {roughness: 1.2}],
  ['spheres-sun', 'the field of view 0.5 degrees wider', {fovY: 0.5}],
  ['spot-light', 'every light\'s range 10% longer', {range: 1.1}],
  ['spot-light', 'the spot\'s outer cone 0.03 radians wider', {coneRadians: 0.03}],
  ['normal-map', 'the bumps as dents (a flipped tangent frame)', {normalScale: -1}],
  ['normal-map', 'the bumps 20% flatter', {normalScale: 0.8}],
  ['alpha-blend', 'every blended surface 15% more opaque', {opacity: 1.15}],
  ['alpha-blend', 'the blended surfaces drawn in the file\'s order (nearest first), not back to front', {fileOrder: true}],
  ['morph-cube-1.9', 'the animation 0.1 s later', {timeOffset: 0.1}],
  ['simple-skin-2.2', 'the animation 0.25 s later', {timeOffset: 0.25}],
  ['column-1.3', 'the animation 0.1 s later', {timeOffset: 0.1}],
  ['column-0.5', 'the STEP morph weights interpolated linearly', {stepAsLinear: true}],
  ['emissive-strength', 'KHR_materials_emissive_strength ignored (strength 1)', {emissiveStrength: 0}],
  ['texture-transform', 'KHR_texture_transform ignored', {noTextureTransform: true}],
  ['ior-specular', 'KHR_materials_ior and _specular ignored (ior 1.5, specular 1)', {iorSpecular: false}],
  ['clearcoat', 'KHR_materials_clearcoat ignored (no coat)', {clearcoat: false}],
  ['sheen', 'KHR_materials_sheen ignored (no sheen)', {sheen: false}],
];

const args = process.argv.slice(2);
const flags = new Set(args.filter((a) => a.startsWith('--') && a !== '--case'));
const only = args.flatMap((a, i) => (args[i - 1] === '--case' ? [a] : []));
const positional = args.filter((a, i) => !a.startsWith('--') && args[i - 1] !== '--case');
const [serverPath, outDirArg] = positional;
if (!serverPath || !outDirArg) {
  console.error('usage: node judge_test.mjs <myriad-server> <output dir> [--pending] [--save] [--case NAME]...');
  process.exit(2);
}
if (!existsSync(CHROMIUM)) {
  console.log(`SKIP: ${CHROMIUM} is absent (scripts/install-deps.sh --with-test-tools installs it).`);
  process.exit(77);
}
let chromium;
try {
  ({chromium} = await import('playwright-core'));
} catch (e) {
  console.error(`playwright-core is not installed (${e.message}); run "npm ci" in tests/judge (scripts/test.sh does it).`);
  process.exit(1);
}
const outDir = resolve(outDirArg);
mkdirSync(outDir, {recursive: true});

const cases = CASES.filter((c) => (only.length ? only.includes(c.name) : true))
                   .filter((c) => !c.pending || flags.has('--pending') || only.includes(c.name));
const selected = [...cases];  // `cases` loses those Myriad cannot render
const models = new Map(cases.map((c) => [c.file, c.bytes()]));

// ---- Myriad ----

const failures = [];
const report = [];
const server = await startServer(serverPath, ['--validate', '--port', '0', '--lights', '0']);
async function api(method, path, {token, json, body, contentType} = {}) {
  const headers = {};
  if (token) headers.Authorization = `Bearer ${token}`;
  if (json !== undefined) headers['Content-Type'] = 'application/json';
  if (contentType) headers['Content-Type'] = contentType;
  // Bounded: a request that hangs fails its case instead of the whole CTest timing out.
  const response = await fetch(server.url + path, {method, headers, signal: AbortSignal.timeout(REQUEST_MS),
    body: json !== undefined ? JSON.stringify(json) : body})
      .catch((e) => { throw new Error(`${method} ${path}: ${e.name === 'TimeoutError' ? `no answer within ${REQUEST_MS} ms` : e.message}`); });
  const bytes = Buffer.from(await response.arrayBuffer());
  if (!response.ok) {
    throw new Error(`${method} ${path}: ${response.status} ${bytes.toString('utf8').slice(0, 400)}`);
  }
  return {response, bytes, json: () => JSON.parse(bytes.toString('utf8'))};
}

function floats(bytes) {
  return new Float32Array(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length));
}

async function renderMyriad(c) {
  const {id, token} = (await api('POST', '/v1/sessions', {json: {}})).json();
  const s = `/v1/sessions/${id}`;
  try {
    const loaded = (await api('PUT', `${s}/model?filename=${encodeURIComponent(c.file)}&lights=model`,
                              {token, body: models.get(c.file), contentType: 'application/octet-stream'})).json();
    // Lights of the case besides the file's: the same light through the API (Myriad) and as a
    // three.js PointLight / SpotLight (decay 2, distance = radius).
    if (c.lights?.length) {
      await api('POST', `${s}/lights`, {token, json: {lights: c.lights.map((l) => ({
        type: l.type, attenuation: 'inverse-square', position: l.position, radius: l.range, color: l.color,
        intensity: l.intensity, falloff: 0,
        ...(l.type === 'spot' ? {direction: l.direction, innerConeAngle: l.innerConeAngle,
                                 outerConeAngle: l.outerConeAngle} : {})}))}});
    }
    const camera = (await api('PUT', `${s}/camera`, {token, json: c.camera})).json();
    const settings = {sun: c.sun, ambient: [0, 0, 0], background: [0, 0, 0], exposure: 1, markers: false};
    // The environment light (issue 12) is off for the judge, its background too: a loaded model
    // starts under the sky. (A server without environments has no such member.)
    const current = (await api('GET', `${s}/settings`, {token})).json();
    if (current.environment !== undefined) {
      settings.environment = {mode: 'none', background: false};
    }
    // three.js renders these cases without shadows: Myriad's sun shadows (on by default in a
    // session) go off for the comparison.
    if (current.shadows !== undefined) settings.shadows = {sun: false};
    await api('PATCH', `${s}/settings`, {token, json: settings});
    const lights = (await api('GET', `${s}/lights`, {token})).json();
    const frame = async (target) => {
      const time = c.time !== undefined ? `&time=${c.time}` : '';
      const r = await api('GET', `${s}/frame?target=${target}&format=raw&width=${c.width}&height=${c.height}${time}`, {token});
      return floats(r.bytes);
    };
    return {final: await frame('final'), depth: await frame('depth'), lights, camera,
            ignored: loaded.model.ignoredExtensions ?? []};
  } finally {
    await api('DELETE', s, {token}).catch(() => {});
  }
}

// ---- three.js in Chromium ----

// Whatever fails below, the server and the browser do not outlive the test.
let browser = null;
let info = {device: {}, validation: {messages: 0}};
let threeVersion = '';
const started = performance.now();
try {
  browser = await chromium.launch({
    executablePath: CHROMIUM,
    // WebGL 2 on the CPU, ANGLE over SwiftShader, whatever GPU the machine has: the flags pin it
    // (Debian's Chromium 156 headless also falls back to it by itself where there is no GPU; newer
    // ones need --enable-unsafe-swiftshader for WebGL on SwiftShader).
    args: ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
  });
  const TYPES = {'.js': 'text/javascript', '.mjs': 'text/javascript', '.html': 'text/html',
                 '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json'};

  async function openPage(mode) {
    const page = await browser.newPage();
    const consoleErrors = [];
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    page.on('pageerror', (e) => consoleErrors.push(e.message));
    // Everything the page loads comes from here: no network, no file:// origin.
    await page.route(`${ORIGIN}/**`, async (route) => {
      const path = new URL(route.request().url()).pathname;
      let body;
      if (path === '/index.html') {
        body = `<!doctype html><html><body><script type="importmap">{"imports": {
          "three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/"}}</script>
          <script type="module" src="/page/three_render.mjs"></script></body></html>`;
      } else if (path.startsWith('/three/')) {
        body = readFileSync(join(HERE, 'node_modules', path.slice(1)));
      } else if (path.startsWith('/page/')) {
        body = readFileSync(join(HERE, path.slice(1)));
      } else if (path.startsWith('/models/')) {
        body = models.get(decodeURIComponent(path.slice('/models/'.length)));
      }
      if (body === undefined) return route.fulfill({status: 404, body: 'not found'});
      return route.fulfill({status: 200, body, contentType: TYPES[extname(path)] || 'application/octet-stream'});
    });
    await page.goto(`${ORIGIN}/index.html?mode=${mode}`);
    await page.waitForFunction(() => window.judgeReady === true || window.judgeError, null, {timeout: 60000})
              .catch((e) => { throw new Error(`the three.js page did not start: ${consoleErrors.join('; ') || e.message}`); });
    return {page, consoleErrors};
  }

  async function renderThree(page, c, perturb) {
    const spec = {model: `${ORIGIN}/models/${encodeURIComponent(c.file)}`, width: c.width, height: c.height,
                  camera: myriad.get(c.name).camera, sun: c.sun, lights: c.lights || [], perturb, time: c.time,
                  anisotropy: myriadAnisotropy};
    const result = await page.evaluate((s) => window.renderCase(s), spec);
    return {rgba: floats(Buffer.from(result.rgba, 'base64')), lights: result.lights, revision: result.revision,
            renderer: result.renderer};
  }

  // ---- the comparison ----

  // Myriad filters textures 16x anisotropically on a GPU and not at all on a CPU implementation
  // (render/textures.cpp: lavapipe's software anisotropic filter is far too slow); three.js samples
  // the same way, or the maps' detail differs texel by texel (DamagedHelmet: 4x4 blocks' p95 0.097
  // with 16x against Myriad's 1x on lavapipe).
  const myriadAnisotropy = (await api('GET', '/v1/info')).json().device.isCpu ? 1 : 16;
  const myriad = new Map();
  for (const c of selected) {
    const t0 = performance.now();
    try {
      myriad.set(c.name, await renderMyriad(c));
      console.log(`myriad ${c.name}: ${Math.round(performance.now() - t0)} ms`);
    } catch (e) {
      // A refusal (a member this server does not know yet) is the answer for a pending case.
      console.log(`${c.pending ? 'PEND' : 'FAIL'} ${c.name}: Myriad could not render it: ${e.message}`);
      if (!c.pending) failures.push(`${c.name}: ${e.message}`);
      cases.splice(cases.indexOf(c), 1);
    }
  }
  // Every case's file uses only glTF extensions Myriad honours, so none is listed as ignored; a
  // file with one it does not (KHR_materials_transmission) has it named in the model summary, and
  // one with an honoured extension's texture that is not read has that named.
  for (const [name, m] of myriad) {
    if (m.ignored.length) failures.push(`${name}: the model summary lists ${m.ignored.join(', ')} as ignored`);
  }
  {
    const {id, token} = (await api('POST', '/v1/sessions', {json: {}})).json();
    const state = (await api('PUT', `/v1/sessions/${id}/model?filename=unsupported.glb`,
                             {token, body: unsupportedGlb(), contentType: 'application/octet-stream'})).json();
    const ignored = JSON.stringify(state.model.ignoredExtensions ?? []);
    const expected = JSON.stringify(['KHR_materials_sheen (sheenColorTexture)', 'KHR_materials_transmission']);
    console.log(`${ignored === expected ? 'ok  ' : 'FAIL'} a file using KHR_materials_transmission and a sheen texture: the summary's ignoredExtensions ${ignored}`);
    if (ignored !== expected) failures.push(`unsupported.glb: ignoredExtensions ${ignored}, not ${expected}`);
    await api('DELETE', `/v1/sessions/${id}`, {token}).catch(() => {});
  }
  const three = {spec: new Map(), stock: new Map()};

  for (const mode of ['spec', 'stock']) {
    const t0 = performance.now();
    const {page, consoleErrors} = await openPage(mode);
    for (const c of cases) {
      const r = await renderThree(page, c);
      three[mode].set(c.name, r);
      threeVersion = `three.js r${r.revision} on ${r.renderer}`;
    }
    // The judge must be able to fail: small deliberate errors in the three.js image must each
    // break the tolerance.
    for (const [name, what, perturb] of mode === 'spec' ? SENSITIVITY : []) {
      const c = cases.find((x) => x.name === name);
      if (!c) continue;
      const m = myriad.get(c.name);
      const r = await renderThree(page, c, perturb);
      const stats = compare(c.width, c.height, m.final, m.depth, m.camera.far, r.rgba, 3, c.block ?? 1).stats;
      const broken = verdict(stats, TOLERANCE);
      console.log(`${broken.length ? 'ok  ' : 'FAIL'} sensitivity ${c.name}, three.js with ${what}: ` +
                  `${broken.length ? 'rejected' : 'NOT rejected'} (mean ${stats.mean.toFixed(4)} ` +
                  `p95 ${stats.p95.toFixed(4)} bias ${stats.bias.map((b) => b.toFixed(4)).join(',')} ` +
                  `coverage-mismatch ${stats.coverageMismatch})`);
      if (!broken.length) failures.push(`the judge cannot tell ${c.name} from three.js with ${what}`);
    }
    if (consoleErrors.length) failures.push(`${mode}: the three.js page logged errors: ${consoleErrors.join('; ')}`);
    await page.close();
    console.log(`three.js ${mode}: ${Math.round(performance.now() - t0)} ms`);
  }
  await browser.close();
  browser = null;

  const f = (v, d = 4) => Number(v).toFixed(d);
  const summary = (st) => `mean ${f(st.mean)} p95 ${f(st.p95)} p99 ${f(st.p99)} max ${f(st.max, 3)} ` +
                          `bias ${st.bias.map((b) => f(b)).join(',')}`;

  function save(c, label, M, T, result, scale) {
    const pics = pictures(c.width, c.height, M, T, result, scale);
    const base = join(outDir, `${c.name}-${label}`);
    writeFileSync(`${base}-myriad.png`, writePng(c.width, c.height, 3, pics.myriad));
    writeFileSync(`${base}-three.png`, writePng(c.width, c.height, 3, pics.three));
    writeFileSync(`${base}-diff.png`, writePng(c.width, c.height, 3, pics.diff));
    return `${base}-{myriad,three,diff}.png (diff: red = Myriad brighter, blue = darker, full at ${scale}; ` +
           'yellow = geometry in one image only; grey = the excluded band)';
  }

  for (const c of cases) {
    const m = myriad.get(c.name);
    const spec = three.spec.get(c.name);
    const stock = three.stock.get(c.name);
    const compareTo = (T, M = m.final, stride = 3) => compare(c.width, c.height, M, m.depth, m.camera.far, T, stride,
                                                             c.block ?? 1);
    // The verdict: Myriad against three.js with the spec's BRDF.
    const judged = compareTo(spec.rgba);
    const broken = verdict(judged.stats, TOLERANCE);
    // Informative, and a consistency check: Myriad against stock three.js may differ by no more than
    // stock three.js differs from spec three.js (the model differences, measured on the same pixels)
    // plus the tolerance above.
    const model = compareTo(stock.rgba, spec.rgba, 4);
    const asShipped = compareTo(stock.rgba);
    const explained = {mean: model.stats.mean + TOLERANCE.mean, p95: model.stats.p95 + TOLERANCE.p95};
    if (!(asShipped.stats.mean <= explained.mean && asShipped.stats.p95 <= explained.p95)) {
      broken.push(`against stock three.js (${summary(asShipped.stats)}) Myriad differs by more than the model ` +
                  `differences (${summary(model.stats)}) plus the tolerance`);
    }
    const st = judged.stats;
    const status = broken.length === 0 ? 'ok  ' : c.pending ? 'PEND' : 'FAIL';
    console.log(`${status} ${c.name.padEnd(15)} ${summary(st)} compared ${st.compared}/${st.pixels} ` +
                `coverage-mismatch ${st.coverageMismatch} white ${f(st.white, 3)}`);
    console.log(`     vs stock three.js: ${summary(asShipped.stats)}; model differences alone: ${summary(model.stats)}`);
    report.push({case: c.name, what: c.what, pending: c.pending ?? null, broken, spec: st, stock: asShipped.stats,
                 modelDifference: model.stats, myriadLights: m.lights, threeLights: spec.lights});
    if (broken.length && !c.pending) failures.push(`${c.name}: ${broken.join('; ')}`);
    if (broken.length) console.log(`     ${broken.join('\n     ')}`);
    if (flags.has('--save-raw')) {
      const base = join(outDir, c.name);
      writeFileSync(`${base}-myriad-final.f32`, m.final);
      writeFileSync(`${base}-myriad-depth.f32`, m.depth);
      writeFileSync(`${base}-three-spec.f32`, spec.rgba);
      writeFileSync(`${base}-three-stock.f32`, stock.rgba);
    }
    if (broken.length || flags.has('--save')) {
      const where = save(c, 'spec', m.final, spec.rgba, judged, TOLERANCE.p95 * 2);
      save(c, 'stock', m.final, stock.rgba, asShipped, TOLERANCE.p95 * 2);
      console.log(`     images: ${where}; the same against stock three.js: ${c.name}-stock-*.png`);
    }
  }

  info = (await api('GET', '/v1/info')).json();
  if (info.validation.messages !== 0) failures.push(`${info.validation.messages} Vulkan validation messages`);
} catch (e) {
  failures.push(`the judge itself failed: ${e.stack}`);
} finally {
  await browser?.close().catch(() => {});
}
const status = await server.stop();
if (status !== 0) failures.push(`myriad-server exited with ${status}`);

writeFileSync(join(outDir, 'judge-report.json'), JSON.stringify(report, null, 1));
const waiting = CASES.filter((c) => c.pending && !selected.includes(c));
for (const c of waiting) console.log(`not judged (pending; --pending renders it): ${c.name} (${c.what}): ${c.pending}`);
console.log(`Myriad on ${info.device.name} (${info.device.driverName}), ${threeVersion}; ${Math.round(performance.now() - started)} ms; ` +
            `report: ${join(outDir, 'judge-report.json')}`);
if (failures.length) {
  console.log(`FAILED:\n  ${failures.join('\n  ')}`);
  process.exit(1);
}
console.log('PASS');
