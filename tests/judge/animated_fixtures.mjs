// Animated models for the judge (issue 29): the glTF sample AnimatedMorphCube made one file (its
// .bin embedded as a data URI), and a model generated here that is skinned, morphed and
// node-animated at once, with one sampler of each interpolation (LINEAR translation,
// CUBICSPLINE joint rotation, STEP morph weights).

import {readFileSync} from 'node:fs';

const MORPH_CUBE = '/usr/share/assimp/models/glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF';

// AnimatedMorphCube.gltf with AnimatedMorphCube.bin inside it: one upload, one three.js URL.
export function morphCubeGltf() {
  const json = JSON.parse(readFileSync(`${MORPH_CUBE}/AnimatedMorphCube.gltf`, 'utf8'));
  const bin = readFileSync(`${MORPH_CUBE}/AnimatedMorphCube.bin`);
  json.buffers[0].uri = `data:application/octet-stream;base64,${bin.toString('base64')}`;
  return Buffer.from(JSON.stringify(json), 'utf8');
}

// One binary buffer and the accessors over it.
class Buffers {
  constructor(json) {
    this.json = json;
    this.chunks = [];
    this.length = 0;
  }

  accessor(array, type, componentType, extra = {}) {
    const padding = (4 - (this.length % 4)) % 4;
    if (padding) {
      this.chunks.push(Buffer.alloc(padding));
      this.length += padding;
    }
    this.json.bufferViews.push({buffer: 0, byteOffset: this.length, byteLength: array.byteLength});
    this.chunks.push(Buffer.from(array.buffer, array.byteOffset, array.byteLength));
    this.length += array.byteLength;
    const components = {SCALAR: 1, VEC3: 3, VEC4: 4}[type];
    const accessor = {bufferView: this.json.bufferViews.length - 1, componentType,
                      count: array.length / components, type, ...extra};
    if (type === 'VEC3' && componentType === 5126) {
      accessor.min = [0, 1, 2].map((c) => Math.min(...array.filter((_, i) => i % 3 === c)));
      accessor.max = [0, 1, 2].map((c) => Math.max(...array.filter((_, i) => i % 3 === c)));
    }
    this.json.accessors.push(accessor);
    return this.json.accessors.length - 1;
  }

  glb() {
    const bin = Buffer.concat(this.chunks);
    const binPadded = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
    this.json.buffers = [{byteLength: binPadded.length}];
    let text = Buffer.from(JSON.stringify(this.json), 'utf8');
    text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
    const header = Buffer.alloc(12);
    header.writeUInt32LE(0x46546c67, 0);
    header.writeUInt32LE(2, 4);
    header.writeUInt32LE(12 + 8 + text.length + 8 + binPadded.length, 8);
    const chunk = (length, type) => {
      const h = Buffer.alloc(8);
      h.writeUInt32LE(length, 0);
      h.writeUInt32LE(type, 4);
      return h;
    };
    return Buffer.concat([header, chunk(text.length, 0x4e4f534a), text, chunk(binPadded.length, 0x004e4942),
                          binPadded]);
  }
}

function axisAngle(axis, degrees) {
  const h = (degrees * Math.PI) / 360;
  const l = Math.hypot(...axis);
  return [...axis.map((a) => (a / l) * Math.sin(h)), Math.cos(h)];
}

// A square column 2 units tall (8 rings of 4 faces, each face its own vertices for flat normals)
// standing on a plinth node: joint 0 at its foot, joint 1 one unit up (the joint's weight blends
// from 0 at y = 0.5 to 1 at y = 1.5); a morph target widening its middle; the plinth node slides
// along +x (LINEAR), joint 1 bends about +z (CUBICSPLINE, tangents non-zero), the morph weight
// jumps 0 -> 1 -> 0.4 (STEP). One clip, 2 s.
export function animatedColumnGlb() {
  const json = {asset: {version: '2.0', generator: 'myriad tests/judge'}, scene: 0, scenes: [{nodes: [0]}],
                nodes: [], meshes: [], skins: [], animations: [], materials: [], accessors: [],
                bufferViews: [], buffers: []};
  const b = new Buffers(json);
  const half = 0.3;
  const rings = 8;
  const positions = [], normals = [], joints = [], weights = [], bulge = [], indices = [];
  const sides = [[[1, 0, 0], [0, 0, -1]], [[0, 0, 1], [1, 0, 0]], [[-1, 0, 0], [0, 0, 1]], [[0, 0, -1], [-1, 0, 0]]];
  for (const [n, t] of sides) {
    const base = positions.length / 3;
    for (let r = 0; r <= rings; ++r) {
      const y = (2 * r) / rings;
      for (const s of [-1, 1]) {
        positions.push(n[0] * half + t[0] * half * s, y, n[2] * half + t[2] * half * s);
        normals.push(...n);
        const w1 = Math.min(1, Math.max(0, y - 0.5));
        joints.push(0, 1, 0, 0);
        weights.push(1 - w1, w1, 0, 0);
        const swell = 0.25 * Math.sin((Math.PI * y) / 2);
        bulge.push(n[0] * swell + t[0] * swell * s, 0, n[2] * swell + t[2] * swell * s);
      }
    }
    for (let r = 0; r < rings; ++r) {
      const a = base + 2 * r;
      indices.push(a, a + 1, a + 3, a, a + 3, a + 2);
    }
  }
  const material = {name: 'clay', pbrMetallicRoughness: {baseColorFactor: [0.75, 0.45, 0.3, 1], metallicFactor: 0,
                                                         roughnessFactor: 0.55}};
  json.materials.push(material);
  const primitive = {
    attributes: {
      POSITION: b.accessor(new Float32Array(positions), 'VEC3', 5126),
      NORMAL: b.accessor(new Float32Array(normals), 'VEC3', 5126),
      JOINTS_0: b.accessor(new Uint16Array(joints), 'VEC4', 5123),
      WEIGHTS_0: b.accessor(new Float32Array(weights), 'VEC4', 5126),
    },
    indices: b.accessor(new Uint16Array(indices), 'SCALAR', 5123),
    material: 0,
    targets: [{POSITION: b.accessor(new Float32Array(bulge), 'VEC3', 5126)}],
  };
  json.meshes.push({name: 'column', primitives: [primitive], weights: [0]});
  // The plinth: a slab under the column, moved by its node alone (no skin).
  const slab = [], slabNormals = [], slabIndices = [];
  const faces = [[[0, 1, 0], [0, 0, 1], [1, 0, 0], 0.0], [[0, 0, 1], [1, 0, 0], [0, 1, 0], 0.6],
                 [[1, 0, 0], [0, 0, -1], [0, 1, 0], 0.6], [[0, 0, -1], [-1, 0, 0], [0, 1, 0], 0.6],
                 [[-1, 0, 0], [0, 0, 1], [0, 1, 0], 0.6]];
  for (const [n, u, v, reach] of faces) {
    const base = slab.length / 3;
    const centre = n[1] === 1 ? [0, 0, 0] : [n[0] * reach, -0.075, n[2] * reach];
    const su = 0.6, sv = n[1] === 1 ? 0.6 : 0.075;
    for (const [a, c] of [[-1, -1], [1, -1], [1, 1], [-1, 1]]) {
      slab.push(centre[0] + u[0] * su * a + v[0] * sv * c, centre[1] + u[1] * su * a + v[1] * sv * c,
                centre[2] + u[2] * su * a + v[2] * sv * c);
      slabNormals.push(...n);
    }
    slabIndices.push(base, base + 1, base + 2, base, base + 2, base + 3);
  }
  json.materials.push({name: 'stone', pbrMetallicRoughness: {baseColorFactor: [0.35, 0.4, 0.45, 1], metallicFactor: 0,
                                                             roughnessFactor: 0.8}});
  json.meshes.push({name: 'slab', primitives: [{attributes: {
    POSITION: b.accessor(new Float32Array(slab), 'VEC3', 5126),
    NORMAL: b.accessor(new Float32Array(slabNormals), 'VEC3', 5126)},
    indices: b.accessor(new Uint16Array(slabIndices), 'SCALAR', 5123), material: 1}]});
  // Nodes: 0 plinth (animated translation, the slab) -> 1 column mesh (skinned), 2 joint0 ->
  // 3 joint1.
  json.nodes.push({name: 'plinth', mesh: 1, translation: [-0.4, 0, 0], children: [1, 2]});
  json.nodes.push({name: 'column', mesh: 0, skin: 0});
  json.nodes.push({name: 'joint0', children: [3]});
  json.nodes.push({name: 'joint1', translation: [0, 1, 0]});
  // Inverse bind matrices: the joints' world transforms at bind time are the plinth's times
  // theirs; binding the column at the plinth's rest place.
  const ibm = (x, y) => [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -x, -y, 0, 1];
  json.skins.push({joints: [2, 3], skeleton: 2,
                   inverseBindMatrices: b.accessor(new Float32Array([...ibm(-0.4, 0), ...ibm(-0.4, 1)]), 'VEC4', 5126,
                                                   {type: 'MAT4', count: 2})});
  const times = b.accessor(new Float32Array([0, 1, 2]), 'SCALAR', 5126);
  const slide = b.accessor(new Float32Array([-0.4, 0, 0, 0.2, 0, 0, 0.5, 0.1, 0]), 'VEC3', 5126);
  // CUBICSPLINE rotation: per key in-tangent, value, out-tangent (quaternions).
  const q0 = axisAngle([0, 0, 1], 0), q1 = axisAngle([0, 0, 1], 35), q2 = axisAngle([0, 0, 1], -20);
  const tan = [0, 0, 0.15, 0];
  const bend = b.accessor(new Float32Array([...tan, ...q0, ...tan, ...tan, ...q1, ...tan, ...tan, ...q2, ...tan]),
                          'VEC4', 5126);
  const swell = b.accessor(new Float32Array([0, 1, 0.4]), 'SCALAR', 5126);
  json.animations.push({name: 'sway', samplers: [
    {input: times, output: slide, interpolation: 'LINEAR'},
    {input: times, output: bend, interpolation: 'CUBICSPLINE'},
    {input: times, output: swell, interpolation: 'STEP'}],
  channels: [
    {sampler: 0, target: {node: 0, path: 'translation'}},
    {sampler: 1, target: {node: 3, path: 'rotation'}},
    {sampler: 2, target: {node: 1, path: 'weights'}}]});
  return b.glb();
}
