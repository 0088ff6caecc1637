// MikkTSpace: Myriad's tangents for a normal-mapped glTF without TANGENT (server/scene/tangents.cpp)
// against the reference implementation's: npm `mikktspace` (mikktspace-wasm: the reference
// mikktspace.c as ported to Rust, compiled to WebAssembly) applied by glTF-Transform's tangents(),
// which writes them into a copy of the file (both pinned by package-lock.json). Myriad renders
// both files through the `normal` target (world normals after normal mapping); per pixel where
// both show a surface, the angle between the two normals must be within 1 degree at the 99th
// percentile. Models: a generated torus whose uvs repeat around it and are mirrored across its
// equators (seams of opposite handedness), and DamagedHelmet where the assets directory has it
// (it has no tangents).
//
// The test must be able to fail: the torus with the reference's tangents of the wrong handedness
// (w negated: every bump a dent) must break the bound.
//
// Usage: node tangents_test.mjs <myriad-server> [assets dir (default /work/shared/assets;
//        MYRIAD_TEST_ASSETS overrides it)]
// Exit 0 pass, 1 fail, 77 skip (this directory's node modules not installed: "npm ci").

import {existsSync, readFileSync} from 'node:fs';
import {join} from 'node:path';
import {startServer} from '../browser/server_process.mjs';
import {writePng} from './fixtures.mjs';

let Document, NodeIO, unweld, tangents, generateTangents;
try {
  ({Document, NodeIO} = await import('@gltf-transform/core'));
  ({unweld, tangents} = await import('@gltf-transform/functions'));
  ({generateTangents} = await import('mikktspace'));
} catch (e) {
  console.log(`SKIP: the reference's node modules are not installed (${e.message}); run "npm ci" in tests/judge.`);
  process.exit(77);
}

const P99_BOUND_DEGREES = 1;
const REQUEST_MS = 120000;  // a model load or a frame on lavapipe with validation

const [serverPath, assetsArg] = process.argv.slice(2);
// As the C++ suites: the environment variable overrides the directory CMake passes.
const assetsDir = process.env.MYRIAD_TEST_ASSETS || assetsArg || '/work/shared/assets';
if (!serverPath) {
  console.error('usage: node tangents_test.mjs <myriad-server> [assets dir]');
  process.exit(2);
}

// A tangent-space normal map of egg-crate bumps (height sin(2 pi 4x) sin(2 pi 4y), slope up to
// 0.8), encoded n * 0.5 + 0.5; +Y of the tangent frame is up the image, as glTF has it.
function bumpsPng(size) {
  const pixels = new Uint8Array(size * size * 3);
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) {
      const ax = 2 * Math.PI * 4 * ((x + 0.5) / size);
      const ay = 2 * Math.PI * 4 * ((y + 0.5) / size);
      const n = [-0.8 * Math.cos(ax) * Math.sin(ay), 0.8 * Math.sin(ax) * Math.cos(ay), 1];
      const l = Math.hypot(...n);
      for (let c = 0; c < 3; ++c) pixels[(y * size + x) * 3 + c] = Math.round((n[c] / l * 0.5 + 0.5) * 255);
    }
  }
  return writePng(size, size, 3, pixels);
}

// A torus (radius 1 around +y, tube 0.4) with that map and no tangents: u runs 4 times around the
// ring, v from 0 on the outer equator over the top to 1 on the inner one and mirrored back under
// it, so the outer and inner equators are seams where the handedness flips.
async function torusGlb() {
  const segments = 96;
  const rings = 48;
  const positions = [];
  const normals = [];
  const uvs = [];
  for (let s = 0; s <= segments; ++s) {
    const phi = (s / segments) * 2 * Math.PI;
    for (let r = 0; r <= rings; ++r) {
      const theta = (r / rings) * 2 * Math.PI;
      const n = [Math.cos(theta) * Math.cos(phi), Math.sin(theta), -Math.cos(theta) * Math.sin(phi)];
      const centre = [Math.cos(phi), 0, -Math.sin(phi)];
      positions.push(...centre.map((c, i) => c + 0.4 * n[i]));
      normals.push(...n);
      uvs.push((4 * s) / segments, 1 - Math.abs(1 - (2 * r) / rings));
    }
  }
  const indices = [];
  for (let s = 0; s < segments; ++s) {
    for (let r = 0; r < rings; ++r) {
      const a = s * (rings + 1) + r;
      const b = a + rings + 1;
      indices.push(a, b, a + 1, a + 1, b, b + 1);  // counter-clockwise seen from outside
    }
  }
  const doc = new Document();
  const buffer = doc.createBuffer();
  const accessor = (type, array) => doc.createAccessor().setType(type).setArray(array).setBuffer(buffer);
  const map = doc.createTexture('bumps').setImage(bumpsPng(128)).setMimeType('image/png');
  const material = doc.createMaterial('bumps').setNormalTexture(map).setBaseColorFactor([0.7, 0.7, 0.65, 1])
                      .setMetallicFactor(0).setRoughnessFactor(0.45);
  const primitive = doc.createPrimitive().setMaterial(material)
                       .setAttribute('POSITION', accessor('VEC3', new Float32Array(positions)))
                       .setAttribute('NORMAL', accessor('VEC3', new Float32Array(normals)))
                       .setAttribute('TEXCOORD_0', accessor('VEC2', new Float32Array(uvs)))
                       .setIndices(accessor('SCALAR', new Uint32Array(indices)));
  doc.createScene().addChild(doc.createNode('torus').setMesh(doc.createMesh('torus').addPrimitive(primitive)));
  return Buffer.from(await new NodeIO().writeBinary(doc));
}

// The file again with the reference's MikkTSpace tangents (glTF-Transform unwelds first, as the
// reference needs, and flips w to glTF's uv convention); `flip` negates w once more.
async function withReferenceTangents(bytes, flip = false) {
  const io = new NodeIO();
  const doc = await io.readBinary(new Uint8Array(bytes));
  const untangented = doc.getRoot().listMeshes().flatMap((m) => m.listPrimitives())
                         .filter((p) => !p.getAttribute('TANGENT')).length;
  await doc.transform(unweld(), tangents({generateTangents}));
  for (const prim of doc.getRoot().listMeshes().flatMap((m) => m.listPrimitives())) {
    const tangent = prim.getAttribute('TANGENT');
    if (!tangent) throw new Error('glTF-Transform wrote no TANGENT for a primitive');
    if (flip) {
      const array = tangent.getArray().slice();
      for (let i = 3; i < array.length; i += 4) array[i] = -array[i];
      tangent.setArray(array);
    }
  }
  return {bytes: Buffer.from(await io.writeBinary(doc)), untangented};
}

const camera = (eye, target, fovY, near, far) => ({eye, target, up: [0, 1, 0], fovY, near, far});
const models = [
  {name: 'torus', bytes: await torusGlb(), width: 384, height: 384, camera: camera([0, 1.9, 2.3], [0, 0, 0], 45, 0.5, 20)},
];
const helmet = join(assetsDir, 'DamagedHelmet', 'DamagedHelmet.glb');
if (existsSync(helmet)) {
  models.push({name: 'DamagedHelmet', bytes: readFileSync(helmet), width: 512, height: 512,
               camera: camera([0.9, 0.5, 3.4], [0, 0, 0], 40, 0.5, 20)});
} else {
  console.log(`note: ${helmet} is absent: DamagedHelmet not compared`);
}

const server = await startServer(serverPath, ['--validate', '--port', '0', '--lights', '0']);
const failures = [];

async function api(method, path, {token, json, body, contentType} = {}) {
  const headers = {};
  if (token) headers.Authorization = `Bearer ${token}`;
  if (json !== undefined) headers['Content-Type'] = 'application/json';
  if (contentType) headers['Content-Type'] = contentType;
  const response = await fetch(server.url + path, {method, headers, signal: AbortSignal.timeout(REQUEST_MS),
    body: json !== undefined ? JSON.stringify(json) : body});
  const bytes = Buffer.from(await response.arrayBuffer());
  if (!response.ok) throw new Error(`${method} ${path}: ${response.status} ${bytes.toString('utf8').slice(0, 400)}`);
  return {bytes, json: () => JSON.parse(bytes.toString('utf8'))};
}

// The `normal` target of `bytes` loaded into a fresh session: x, y, z per pixel, zero off the model.
async function renderNormals(model, bytes) {
  const {id, token} = (await api('POST', '/v1/sessions', {json: {}})).json();
  const s = `/v1/sessions/${id}`;
  try {
    await api('PUT', `${s}/model?filename=${model.name}.glb`, {token, body: bytes, contentType: 'application/octet-stream'});
    await api('PUT', `${s}/camera`, {token, json: model.camera});
    const r = await api('GET', `${s}/frame?target=normal&format=raw&width=${model.width}&height=${model.height}`, {token});
    const normals = new Float32Array(r.bytes.buffer.slice(r.bytes.byteOffset, r.bytes.byteOffset + r.bytes.length));
    if (normals.length !== model.width * model.height * 3) {
      throw new Error(`the raw normal frame has ${normals.length} floats, not ${model.width * model.height * 3}`);
    }
    return normals;
  } finally {
    await api('DELETE', s, {token}).catch(() => {});
  }
}

// Angles in degrees between the normals of the pixels both images cover, and how many pixels only
// one covers (the geometry is the same, so there should be none).
function compareNormals(a, b) {
  const angles = [];
  let onlyOne = 0;
  for (let i = 0; i < a.length; i += 3) {
    const la = Math.hypot(a[i], a[i + 1], a[i + 2]);
    const lb = Math.hypot(b[i], b[i + 1], b[i + 2]);
    if ((la > 0.5) !== (lb > 0.5)) ++onlyOne;
    if (la <= 0.5 || lb <= 0.5) continue;
    const cos = (a[i] * b[i] + a[i + 1] * b[i + 1] + a[i + 2] * b[i + 2]) / (la * lb);
    angles.push((Math.acos(Math.min(1, Math.max(-1, cos))) * 180) / Math.PI);
  }
  angles.sort((x, y) => x - y);
  const at = (q) => angles[Math.min(angles.length - 1, Math.floor(q * angles.length))] ?? NaN;
  const mean = angles.reduce((sum, x) => sum + x, 0) / angles.length;
  return {pixels: angles.length, onlyOne, mean, p50: at(0.5), p95: at(0.95), p99: at(0.99), max: angles.at(-1) ?? NaN};
}

const f = (x) => x.toFixed(3);
const line = (st) => `p99 ${f(st.p99)} deg (mean ${f(st.mean)}, p50 ${f(st.p50)}, p95 ${f(st.p95)}, max ${f(st.max)}) ` +
                     `over ${st.pixels} pixels, ${st.onlyOne} covered in one image only`;
try {
  for (const model of models) {
    const reference = await withReferenceTangents(model.bytes);
    if (reference.untangented === 0) failures.push(`${model.name}: the file already has tangents, so it tests nothing`);
    const mine = await renderNormals(model, model.bytes);
    const theirs = await renderNormals(model, reference.bytes);
    const st = compareNormals(mine, theirs);
    const ok = st.p99 <= P99_BOUND_DEGREES && st.pixels > 0.05 * model.width * model.height &&
               st.onlyOne <= 0.001 * st.pixels;
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${model.name}: Myriad's tangents vs the reference's: ${line(st)}`);
    if (!ok) failures.push(`${model.name}: ${line(st)}; the bound is p99 <= ${P99_BOUND_DEGREES} deg`);

    if (model.name === 'torus') {
      const flipped = await withReferenceTangents(model.bytes, true);
      const wrong = compareNormals(mine, await renderNormals(model, flipped.bytes));
      const rejected = wrong.p99 > P99_BOUND_DEGREES;
      console.log(`${rejected ? 'ok  ' : 'FAIL'} sensitivity ${model.name}, the reference's tangents with w negated: ` +
                  `${rejected ? 'rejected' : 'NOT rejected'}: ${line(wrong)}`);
      if (!rejected) failures.push(`the test cannot tell ${model.name}'s tangents from the wrong handedness`);
    }
  }
  const info = (await api('GET', '/v1/info')).json();
  if (info.validation.messages !== 0) failures.push(`${info.validation.messages} Vulkan validation messages`);
  console.log(`Myriad on ${info.device.name} (${info.device.driverName})`);
} catch (e) {
  failures.push(`the test itself failed: ${e.stack}`);
}
const status = await server.stop();
if (status !== 0) failures.push(`myriad-server exited with ${status}`);
if (failures.length) {
  console.log(`FAILED:\n  ${failures.join('\n  ')}`);
  process.exit(1);
}
console.log('PASS');
