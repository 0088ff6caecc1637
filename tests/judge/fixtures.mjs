// The judge's own glTF test files, written here as GLB (nothing binary in the repository): spheres
// of several materials, a normal-mapped quad and sphere, an alpha-MASK cut-out in front of a
// backdrop, and a floor lit by a KHR_lights_punctual spot and point light. Images are PNGs written
// by writePng (zlib from Node, CRC-32 below).

import {deflateSync} from 'node:zlib';

// ---- PNG ----

const crcTable = (() => {
  const table = new Uint32Array(256);
  for (let n = 0; n < 256; ++n) {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    table[n] = c >>> 0;
  }
  return table;
})();

function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

function pngChunk(type, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(type, 4, 'latin1');
  Buffer.from(data).copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}

// 8-bit RGBA (channels 4) or RGB (channels 3), rows top first.
export function writePng(width, height, channels, pixels) {
  const stride = width * channels;
  const raw = Buffer.alloc((stride + 1) * height);
  for (let y = 0; y < height; ++y) {
    raw[y * (stride + 1)] = 0;  // filter: none
    Buffer.from(pixels.buffer, pixels.byteOffset + y * stride, stride).copy(raw, y * (stride + 1) + 1);
  }
  const header = Buffer.alloc(13);
  header.writeUInt32BE(width, 0);
  header.writeUInt32BE(height, 4);
  header[8] = 8;
  header[9] = channels === 4 ? 6 : 2;
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
                        pngChunk('IHDR', header), pngChunk('IDAT', deflateSync(raw)),
                        pngChunk('IEND', Buffer.alloc(0))]);
}

// ---- GLB ----

// Collects accessors, images and nodes into one glTF document with one binary buffer.
class GltfBuilder {
  constructor() {
    this.json = {asset: {version: '2.0', generator: 'myriad tests/judge'}, scenes: [{nodes: []}],
                 scene: 0, nodes: [], meshes: [], materials: [], accessors: [], bufferViews: [],
                 buffers: []};
    this.chunks = [];
    this.length = 0;
  }

  view(bytes, target) {
    const padding = (4 - (this.length % 4)) % 4;
    if (padding) {
      this.chunks.push(Buffer.alloc(padding));
      this.length += padding;
    }
    const view = {buffer: 0, byteOffset: this.length, byteLength: bytes.byteLength};
    if (target) view.target = target;
    this.chunks.push(Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength));
    this.length += bytes.byteLength;
    this.json.bufferViews.push(view);
    return this.json.bufferViews.length - 1;
  }

  accessor(array, type, target) {
    const components = {SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4}[type];
    const accessor = {bufferView: this.view(array, target), count: array.length / components, type,
                      componentType: array instanceof Uint32Array ? 5125 : 5126};
    if (type === 'VEC3' && !(array instanceof Uint32Array)) {
      accessor.min = [0, 1, 2].map((c) => Math.min(...array.filter((_, i) => i % 3 === c)));
      accessor.max = [0, 1, 2].map((c) => Math.max(...array.filter((_, i) => i % 3 === c)));
    }
    this.json.accessors.push(accessor);
    return this.json.accessors.length - 1;
  }

  image(png) {
    this.json.images ??= [];
    this.json.textures ??= [];
    this.json.samplers ??= [{magFilter: 9729, minFilter: 9987, wrapS: 10497, wrapT: 10497}];
    this.json.images.push({bufferView: this.view(png), mimeType: 'image/png'});
    this.json.textures.push({source: this.json.images.length - 1, sampler: 0});
    return this.json.textures.length - 1;
  }

  material(material) {
    this.json.materials.push(material);
    return this.json.materials.length - 1;
  }

  mesh(geometry, material) {
    const attributes = {POSITION: this.accessor(geometry.positions, 'VEC3', 34962),
                        NORMAL: this.accessor(geometry.normals, 'VEC3', 34962),
                        TEXCOORD_0: this.accessor(geometry.uvs, 'VEC2', 34962)};
    if (geometry.tangents) attributes.TANGENT = this.accessor(geometry.tangents, 'VEC4', 34962);
    const indices = this.accessor(geometry.indices, 'SCALAR', 34963);
    this.json.meshes.push({primitives: [{attributes, indices, material}]});
    return this.json.meshes.length - 1;
  }

  node(node) {
    this.json.nodes.push(node);
    this.json.scenes[0].nodes.push(this.json.nodes.length - 1);
    return this.json.nodes.length - 1;
  }

  glb() {
    const bin = Buffer.concat(this.chunks);
    const binPadded = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
    this.json.buffers = [{byteLength: binPadded.length}];
    let text = Buffer.from(JSON.stringify(this.json), 'utf8');
    text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
    const header = Buffer.alloc(12);
    header.writeUInt32LE(0x46546c67, 0);  // glTF
    header.writeUInt32LE(2, 4);
    header.writeUInt32LE(12 + 8 + text.length + 8 + binPadded.length, 8);
    const chunkHeader = (length, type) => {
      const h = Buffer.alloc(8);
      h.writeUInt32LE(length, 0);
      h.writeUInt32LE(type, 4);
      return h;
    };
    return Buffer.concat([header, chunkHeader(text.length, 0x4e4f534a), text,
                          chunkHeader(binPadded.length, 0x004e4942), binPadded]);
  }
}

// ---- geometry ----

// A UV sphere of radius 1 at the origin; tangents (along +u, w = 1) when asked.
function sphere(segments, rings, withTangents) {
  const positions = [];
  const normals = [];
  const uvs = [];
  const tangents = [];
  for (let r = 0; r <= rings; ++r) {
    const v = r / rings;
    const theta = v * Math.PI;
    for (let s = 0; s <= segments; ++s) {
      const u = s / segments;
      const phi = u * 2 * Math.PI;
      const n = [Math.sin(theta) * Math.sin(phi), Math.cos(theta), Math.sin(theta) * Math.cos(phi)];
      positions.push(...n);
      normals.push(...n);
      uvs.push(u, v);
      tangents.push(Math.cos(phi), 0, -Math.sin(phi), 1);
    }
  }
  const indices = [];
  for (let r = 0; r < rings; ++r) {
    for (let s = 0; s < segments; ++s) {
      const a = r * (segments + 1) + s;
      const b = a + segments + 1;
      indices.push(a, b, a + 1, a + 1, b, b + 1);
    }
  }
  return {positions: new Float32Array(positions), normals: new Float32Array(normals),
          uvs: new Float32Array(uvs), indices: new Uint32Array(indices),
          tangents: withTangents ? new Float32Array(tangents) : undefined};
}

// A unit quad in the XY plane facing +Z, uv (0,0) at its top-left corner as glTF has it.
function quad() {
  return {positions: new Float32Array([-0.5, -0.5, 0, 0.5, -0.5, 0, 0.5, 0.5, 0, -0.5, 0.5, 0]),
          normals: new Float32Array([0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1]),
          uvs: new Float32Array([0, 1, 1, 1, 1, 0, 0, 0]),
          indices: new Uint32Array([0, 1, 2, 0, 2, 3])};
}

// A node rotation (quaternion x, y, z, w) turning +Z (a quad's normal) or -Z (a light's
// direction) by `degrees` about `axis`.
function rotation(axis, degrees) {
  const h = (degrees * Math.PI) / 360;
  const l = Math.hypot(...axis);
  return [...axis.map((a) => (a / l) * Math.sin(h)), Math.cos(h)];
}

// ---- images ----

// A tangent-space normal map of smooth bumps on a 4x4 grid (height (1 - r^2)^2 inside radius 0.4 of
// a cell: the slope is continuous, so bilinear filtering has no crease to round differently),
// encoded n * 0.5 + 0.5.
function bumpNormalMap(size) {
  const pixels = new Uint8Array(size * size * 3);
  const cell = size / 4;
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) {
      const cx = ((x + 0.5) % cell) / cell - 0.5;
      // Image rows go down while +Y of the tangent frame is up in the image (glTF): bitangent = -y.
      const cy = -(((y + 0.5) % cell) / cell - 0.5);
      const r2 = (cx * cx + cy * cy) / 0.16;
      let n = [0, 0, 1];
      if (r2 < 1) {
        // n = (-dh/dx, -dh/dy, 1) scaled: tilted outwards, steepest (slope ~1.2) halfway out.
        const k = 0.3 * 4 * (1 - r2) / 0.16;
        n = [cx * k, cy * k, 1];
        const l = Math.hypot(...n);
        n = n.map((c) => c / l);
      }
      for (let c = 0; c < 3; ++c) pixels[(y * size + x) * 3 + c] = Math.round((n[c] * 0.5 + 0.5) * 255);
    }
  }
  return writePng(size, size, 3, pixels);
}

// RGBA: a colour gradient, alpha a ring of discs fading from 1 inside to 0 outside so the cutoff
// (0.5) draws the edge; the texture is magnified, so filtering is smooth around it.
function maskTexture(size) {
  const pixels = new Uint8Array(size * size * 4);
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) {
      const u = (x + 0.5) / size;
      const v = (y + 0.5) / size;
      const i = (y * size + x) * 4;
      pixels[i] = Math.round(255 * (0.2 + 0.8 * u));
      pixels[i + 1] = Math.round(255 * (0.3 + 0.5 * v));
      pixels[i + 2] = Math.round(255 * (0.9 - 0.7 * u));
      const cu = (u * 3) % 1 - 0.5;
      const cv = (v * 3) % 1 - 0.5;
      const d = Math.hypot(cu, cv);
      pixels[i + 3] = Math.round(255 * Math.min(1, Math.max(0, (0.42 - d) / 0.1)));
    }
  }
  return writePng(size, size, 4, pixels);
}

// RGB: a checkerboard of single black and white texels.
function checkerTexture(size) {
  const pixels = new Uint8Array(size * size * 3);
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) pixels.fill((x + y) % 2 ? 255 : 0, (y * size + x) * 3, (y * size + x) * 3 + 3);
  }
  return writePng(size, size, 3, pixels);
}

// ---- the models ----

// Four spheres in a row: a rough red dielectric, a gold metal, a glossy white dielectric and a
// half-metallic blue; factors only, no textures.
// With `directional`, the file also carries a KHR_lights_punctual directional light (lux),
// pointing down to the left and away.
export function spheresGlb(directional = false) {
  const b = new GltfBuilder();
  if (directional) {
    b.json.extensionsUsed = ['KHR_lights_punctual'];
    b.json.extensions = {KHR_lights_punctual: {lights: [{name: 'sunlight', type: 'directional',
                                                         color: [1, 0.9, 0.8], intensity: 2.5}]}};
    b.node({name: 'sunlight', rotation: rotation([1, -0.6, 0.2], -50), extensions: {KHR_lights_punctual: {light: 0}}});
  }
  const materials = [
    {name: 'red', pbrMetallicRoughness: {baseColorFactor: [0.8, 0.1, 0.08, 1], metallicFactor: 0, roughnessFactor: 0.6}},
    {name: 'gold', pbrMetallicRoughness: {baseColorFactor: [1.0, 0.77, 0.33, 1], metallicFactor: 1, roughnessFactor: 0.35}},
    {name: 'white', pbrMetallicRoughness: {baseColorFactor: [0.9, 0.9, 0.9, 1], metallicFactor: 0, roughnessFactor: 0.25}},
    {name: 'blue', pbrMetallicRoughness: {baseColorFactor: [0.1, 0.3, 0.9, 1], metallicFactor: 0.5, roughnessFactor: 0.8}},
  ];
  const geometry = sphere(48, 32, false);
  materials.forEach((m, i) => {
    const mesh = b.mesh(geometry, b.material(m));
    b.node({name: m.name, mesh, translation: [(i - 1.5) * 2.2, 0, 0]});
  });
  return b.glb();
}

// A normal-mapped quad (no tangents in the file: generated) and sphere (tangents from the file).
export function normalMapGlb() {
  const b = new GltfBuilder();
  const normalTexture = b.image(bumpNormalMap(128));
  const material = b.material({name: 'bumps', normalTexture: {index: normalTexture, scale: 1},
                               pbrMetallicRoughness: {baseColorFactor: [0.7, 0.7, 0.65, 1],
                                                      metallicFactor: 0, roughnessFactor: 0.45}});
  b.node({name: 'quad', mesh: b.mesh(quad(), material), translation: [-1.2, 0, 0], scale: [2, 2, 1],
          rotation: rotation([0, 1, 0], 25)});
  b.node({name: 'sphere', mesh: b.mesh(sphere(48, 32, true), material), translation: [1.2, 0, 0]});
  return b.glb();
}

// A grey backdrop and, in front of it, a textured quad with alphaMode MASK (cutoff 0.5).
export function maskGlb() {
  const b = new GltfBuilder();
  const backdrop = b.material({name: 'backdrop', pbrMetallicRoughness: {baseColorFactor: [0.5, 0.5, 0.5, 1],
                                                                        metallicFactor: 0, roughnessFactor: 0.9}});
  const cutout = b.material({name: 'cutout', alphaMode: 'MASK', alphaCutoff: 0.5, doubleSided: true,
                             pbrMetallicRoughness: {baseColorTexture: {index: b.image(maskTexture(64))},
                                                    metallicFactor: 0, roughnessFactor: 0.5}});
  b.node({name: 'backdrop', mesh: b.mesh(quad(), backdrop), translation: [0, 0, -1], scale: [5, 4, 1]});
  b.node({name: 'cutout', mesh: b.mesh(quad(), cutout), scale: [2.4, 2.4, 1]});
  return b.glb();
}

// A floor, a sphere and a box-like quad wall, lit by a KHR_lights_punctual spot light (soft
// penumbra) and a point light, both with a range.
export function spotGlb() {
  const b = new GltfBuilder();
  const floor = b.material({name: 'floor', pbrMetallicRoughness: {baseColorFactor: [0.7, 0.7, 0.7, 1],
                                                                  metallicFactor: 0, roughnessFactor: 0.7}});
  const ball = b.material({name: 'ball', pbrMetallicRoughness: {baseColorFactor: [0.9, 0.5, 0.2, 1],
                                                                metallicFactor: 0.2, roughnessFactor: 0.4}});
  b.json.extensionsUsed = ['KHR_lights_punctual'];
  b.json.extensions = {KHR_lights_punctual: {lights: [
    {name: 'spot', type: 'spot', color: [1, 0.95, 0.85], intensity: 40, range: 12,
     spot: {innerConeAngle: 0.3, outerConeAngle: 0.55}},
    {name: 'point', type: 'point', color: [0.4, 0.6, 1], intensity: 6, range: 5},
  ]}};
  b.node({name: 'floor', mesh: b.mesh(quad(), floor), scale: [8, 8, 1], rotation: rotation([1, 0, 0], -90)});
  b.node({name: 'ball', mesh: b.mesh(sphere(48, 32, false), ball), translation: [0.6, 0.8, 0], scale: [0.8, 0.8, 0.8]});
  // The spot above and in front, aimed down at the floor (a light shines along its node's -Z).
  b.node({name: 'spot', translation: [-0.5, 3.5, 1.5], rotation: rotation([1, 0.1, 0], -70),
          extensions: {KHR_lights_punctual: {light: 0}}});
  b.node({name: 'point', translation: [-2, 0.6, -0.5], extensions: {KHR_lights_punctual: {light: 1}}});
  return b.glb();
}

// A quad with a one-texel black-and-white checkerboard as base colour, to be seen minified: each
// pixel then shows the mean of many texels, which is 0.5 in linear light only if the mip chain is
// averaged in linear light (an average of the sRGB codes would be 0.5 sRGB, 0.214 linear).
export function checkerGlb() {
  const b = new GltfBuilder();
  const material = b.material({name: 'checker', pbrMetallicRoughness: {baseColorTexture: {index: b.image(checkerTexture(256))},
                                                                      metallicFactor: 0, roughnessFactor: 0.8}});
  b.node({name: 'quad', mesh: b.mesh(quad(), material)});
  return b.glb();
}

// A grey backdrop and, in front of it, two overlapping alphaMode BLEND quads: the nearer one
// listed first (so drawing in file order would be wrong), a textured one (the mask texture's
// colour and smooth alpha, times 0.8) and a plain orange one of alpha 0.5, single-sided.
export function blendGlb() {
  const b = new GltfBuilder();
  const backdrop = b.material({name: 'backdrop', pbrMetallicRoughness: {baseColorFactor: [0.5, 0.5, 0.5, 1],
                                                                        metallicFactor: 0, roughnessFactor: 0.9}});
  const glass = b.material({name: 'textured-glass', alphaMode: 'BLEND', doubleSided: true,
                            pbrMetallicRoughness: {baseColorTexture: {index: b.image(maskTexture(64))},
                                                   baseColorFactor: [1, 1, 1, 0.8], metallicFactor: 0,
                                                   roughnessFactor: 0.4}});
  const tint = b.material({name: 'orange-tint', alphaMode: 'BLEND', doubleSided: false,
                           pbrMetallicRoughness: {baseColorFactor: [0.95, 0.5, 0.1, 0.5], metallicFactor: 0,
                                                  roughnessFactor: 0.6}});
  b.node({name: 'backdrop', mesh: b.mesh(quad(), backdrop), translation: [0, 0, -1], scale: [5, 4, 1]});
  b.node({name: 'near', mesh: b.mesh(quad(), glass), translation: [0.25, 0.1, 0.4], scale: [1.6, 1.6, 1]});
  b.node({name: 'far', mesh: b.mesh(quad(), tint), translation: [-0.35, -0.2, -0.3], scale: [1.8, 1.5, 1]});
  return b.glb();
}

// ---- material extensions (issue 36) ----

// RGB: smooth stripes and a ramp, so that where a texture transform moves the texture shows
// plainly and magnified filtering has no hard edge to round differently.
function waveTexture(size, [r0, g0, b0], [r1, g1, b1]) {
  const pixels = new Uint8Array(size * size * 3);
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) {
      const u = (x + 0.5) / size;
      const v = (y + 0.5) / size;
      const t = 0.5 + 0.5 * Math.sin(2 * Math.PI * (2 * u + v));
      const i = (y * size + x) * 3;
      pixels[i] = Math.round(255 * (r0 + (r1 - r0) * t));
      pixels[i + 1] = Math.round(255 * (g0 + (g1 - g0) * t * v));
      pixels[i + 2] = Math.round(255 * (b0 + (b1 - b0) * (1 - t)));
    }
  }
  return writePng(size, size, 3, pixels);
}

// Metallic-roughness: roughness (G) in smooth bands along u, metallic (B) along v.
function metallicRoughnessTexture(size) {
  const pixels = new Uint8Array(size * size * 3);
  for (let y = 0; y < size; ++y) {
    for (let x = 0; x < size; ++x) {
      const u = (x + 0.5) / size;
      const v = (y + 0.5) / size;
      const i = (y * size + x) * 3;
      pixels[i] = 255;
      pixels[i + 1] = Math.round(255 * (0.25 + 0.6 * (0.5 + 0.5 * Math.cos(2 * Math.PI * u))));
      pixels[i + 2] = Math.round(255 * (0.5 + 0.5 * Math.sin(2 * Math.PI * v)));
    }
  }
  return writePng(size, size, 3, pixels);
}

// KHR_materials_emissive_strength: a sphere glowing with its emissive factor times 4 and a quad
// whose emissive texture (times a factor) is scaled by 2.5, beside a plain lit sphere, under a
// weak sun (the emission dominates: values above 1 in the linear image).
export function emissiveStrengthGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_emissive_strength'];
  const glow = b.material({name: 'glow', emissiveFactor: [0.6, 0.3, 0.1],
                           extensions: {KHR_materials_emissive_strength: {emissiveStrength: 4}},
                           pbrMetallicRoughness: {baseColorFactor: [0.2, 0.2, 0.2, 1], metallicFactor: 0,
                                                  roughnessFactor: 0.6}});
  const panel = b.material({name: 'panel', emissiveFactor: [0.5, 0.7, 1.0],
                            emissiveTexture: {index: b.image(waveTexture(64, [0.1, 0.2, 0.9], [0.9, 0.8, 0.1]))},
                            extensions: {KHR_materials_emissive_strength: {emissiveStrength: 2.5}},
                            pbrMetallicRoughness: {baseColorFactor: [0.1, 0.1, 0.1, 1], metallicFactor: 0,
                                                   roughnessFactor: 0.8}});
  const plain = b.material({name: 'plain', pbrMetallicRoughness: {baseColorFactor: [0.7, 0.7, 0.7, 1],
                                                                  metallicFactor: 0, roughnessFactor: 0.5}});
  b.node({name: 'glow', mesh: b.mesh(sphere(48, 32, false), glow), translation: [-1.8, 0, 0], scale: [0.8, 0.8, 0.8]});
  b.node({name: 'panel', mesh: b.mesh(quad(), panel), scale: [1.8, 1.8, 1]});
  b.node({name: 'plain', mesh: b.mesh(sphere(48, 32, false), plain), translation: [1.8, 0, 0], scale: [0.8, 0.8, 0.8]});
  return b.glb();
}

// KHR_texture_transform on every slot of one material: base colour (offset and rotation),
// metallic-roughness (scale), normal (offset, rotation and uniform scale), occlusion (offset) and
// emissive (non-uniform scale and offset), on a quad and a sphere. The maps are small enough to be
// magnified even where a transform scales them up (minified, two GPUs' mip choices differ).
export function textureTransformGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_texture_transform'];
  const transform = (offset, rotation, scale) => ({KHR_texture_transform: {offset, rotation, scale}});
  const material = b.material({
    name: 'transformed', emissiveFactor: [0.35, 0.3, 0.25],
    pbrMetallicRoughness: {
      baseColorTexture: {index: b.image(waveTexture(64, [0.9, 0.2, 0.1], [0.2, 0.8, 0.9])),
                         extensions: transform([0.3, -0.2], 0.6, [1, 1])},
      metallicRoughnessTexture: {index: b.image(metallicRoughnessTexture(32)),
                                 extensions: transform([0, 0], 0, [2, 1.5])},
      metallicFactor: 0.5, roughnessFactor: 1},
    normalTexture: {index: b.image(bumpNormalMap(64)), scale: 1,
                    extensions: transform([0.125, 0.1], -0.4, [1.5, 1.5])},
    occlusionTexture: {index: b.image(waveTexture(32, [1, 1, 1], [0.3, 0.3, 0.3])),
                       extensions: transform([0.5, 0.25], 0, [1, 1])},
    emissiveTexture: {index: b.image(waveTexture(32, [0, 0, 0.2], [0.8, 0.5, 0])),
                      extensions: transform([0.2, 0.4], 0, [3, 0.5])}});
  b.node({name: 'quad', mesh: b.mesh(quad(), material), translation: [-1.1, 0, 0], scale: [2, 2, 1],
          rotation: rotation([0, 1, 0], 20)});
  b.node({name: 'sphere', mesh: b.mesh(sphere(48, 32, true), material), translation: [1.2, 0, 0]});
  return b.glb();
}

// KHR_materials_unlit: a textured quad and a plain sphere that show their base colour unlit, and
// a lit sphere of the same colour for contrast, under the sun.
export function unlitGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_unlit'];
  const unlit = {KHR_materials_unlit: {}};
  const poster = b.material({name: 'poster', extensions: unlit,
                             pbrMetallicRoughness: {baseColorTexture: {index: b.image(waveTexture(64, [0.9, 0.3, 0.1], [0.1, 0.5, 0.9]))},
                                                    baseColorFactor: [1, 0.9, 0.8, 1], metallicFactor: 0,
                                                    roughnessFactor: 0.9}});
  const flat = b.material({name: 'flat', extensions: unlit,
                           pbrMetallicRoughness: {baseColorFactor: [0.2, 0.6, 0.3, 1], metallicFactor: 1,
                                                  roughnessFactor: 0.2}});
  const lit = b.material({name: 'lit', pbrMetallicRoughness: {baseColorFactor: [0.2, 0.6, 0.3, 1],
                                                              metallicFactor: 0, roughnessFactor: 0.4}});
  b.node({name: 'poster', mesh: b.mesh(quad(), poster), translation: [0, 0, -0.5], scale: [1.8, 1.8, 1]});
  b.node({name: 'flat', mesh: b.mesh(sphere(48, 32, false), flat), translation: [-1.6, 0, 0], scale: [0.7, 0.7, 0.7]});
  b.node({name: 'lit', mesh: b.mesh(sphere(48, 32, false), lit), translation: [1.6, 0, 0], scale: [0.7, 0.7, 0.7]});
  return b.glb();
}

// A sphere whose material uses KHR_materials_transmission (which Myriad does not honour) and
// KHR_materials_sheen with a colour texture (honoured, its texture not read): the model summary
// must name both, the second as "KHR_materials_sheen (sheenColorTexture)".
export function unsupportedGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_sheen', 'KHR_materials_transmission'];
  const texture = b.image(checkerTexture(4));
  const glass = b.material({name: 'glass', extensions: {KHR_materials_transmission: {transmissionFactor: 1},
                                                        KHR_materials_sheen: {sheenColorFactor: [1, 0.3, 0.3],
                                                                              sheenColorTexture: {index: texture}}},
                            pbrMetallicRoughness: {baseColorFactor: [0.3, 0.05, 0.1, 1], metallicFactor: 0,
                                                   roughnessFactor: 0.8}});
  b.node({name: 'ball', mesh: b.mesh(sphere(24, 16, false), glass)});
  return b.glb();
}

// KHR_materials_clearcoat (factors): four dark, rough spheres, three of them coated (a smooth full
// coat, a half coat, a rougher coat over a rough gold metal) beside an uncoated one, under the sun:
// the coat's highlight over the base's broad one, and the base dimmed by the coat's Fresnel at the
// rims.
export function clearcoatGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_clearcoat'];
  const dark = {baseColorFactor: [0.25, 0.04, 0.05, 1], metallicFactor: 0, roughnessFactor: 0.7};
  const variants = [
    {name: 'uncoated', pbrMetallicRoughness: dark},
    {name: 'coat-1-0.15', pbrMetallicRoughness: dark,
     extensions: {KHR_materials_clearcoat: {clearcoatFactor: 1, clearcoatRoughnessFactor: 0.15}}},
    {name: 'coat-0.5-0.3', pbrMetallicRoughness: dark,
     extensions: {KHR_materials_clearcoat: {clearcoatFactor: 0.5, clearcoatRoughnessFactor: 0.3}}},
    {name: 'gold-coat-0.8-0.4', pbrMetallicRoughness: {baseColorFactor: [1, 0.77, 0.33, 1], metallicFactor: 1,
                                                      roughnessFactor: 0.6},
     extensions: {KHR_materials_clearcoat: {clearcoatFactor: 0.8, clearcoatRoughnessFactor: 0.4}}},
  ];
  const geometry = sphere(48, 32, false);
  variants.forEach((v, i) => {
    b.node({name: v.name, mesh: b.mesh(geometry, b.material(v)), translation: [(i - 1.5) * 2.2, 0, 0]});
  });
  return b.glb();
}

// KHR_materials_sheen (factors): dark, rough, cloth-like spheres with a sheen (pink at roughness
// 0.3, white at 0.7, a blue one at 0.5 under a clear coat too) beside one without, lit from the
// side and a little behind: light and view graze the lit half, where the sheen's glow shows.
export function sheenGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_sheen', 'KHR_materials_clearcoat'];
  const cloth = {baseColorFactor: [0.08, 0.05, 0.1, 1], metallicFactor: 0, roughnessFactor: 0.9};
  const variants = [
    {name: 'plain', pbrMetallicRoughness: cloth},
    {name: 'pink-0.3', pbrMetallicRoughness: cloth,
     extensions: {KHR_materials_sheen: {sheenColorFactor: [1, 0.4, 0.6], sheenRoughnessFactor: 0.3}}},
    {name: 'white-0.7', pbrMetallicRoughness: cloth,
     extensions: {KHR_materials_sheen: {sheenColorFactor: [0.8, 0.8, 0.8], sheenRoughnessFactor: 0.7}}},
    {name: 'blue-0.5-coated', pbrMetallicRoughness: cloth,
     extensions: {KHR_materials_sheen: {sheenColorFactor: [0.3, 0.5, 1], sheenRoughnessFactor: 0.5},
                  KHR_materials_clearcoat: {clearcoatFactor: 0.6, clearcoatRoughnessFactor: 0.3}}},
  ];
  const geometry = sphere(48, 32, false);
  variants.forEach((v, i) => {
    b.node({name: v.name, mesh: b.mesh(geometry, b.material(v)), translation: [(i - 1.5) * 2.2, 0, 0]});
  });
  return b.glb();
}

// KHR_materials_ior and KHR_materials_specular (its factor): four dark, glossy dielectric spheres
// whose reflection of the sun is set by them (ior 1.2, ior 2.0, specular 0.3, ior 1.8 with
// specular 0.5), glTF's default spec (ior 1.5) on a fifth.
export function iorSpecularGlb() {
  const b = new GltfBuilder();
  b.json.extensionsUsed = ['KHR_materials_ior', 'KHR_materials_specular'];
  const variants = [
    {name: 'ior-1.2', extensions: {KHR_materials_ior: {ior: 1.2}}},
    {name: 'ior-2.0', extensions: {KHR_materials_ior: {ior: 2.0}}},
    {name: 'default'},
    {name: 'specular-0.3', extensions: {KHR_materials_specular: {specularFactor: 0.3}}},
    {name: 'ior-1.8-specular-0.5', extensions: {KHR_materials_ior: {ior: 1.8},
                                                KHR_materials_specular: {specularFactor: 0.5}}},
  ];
  const geometry = sphere(48, 32, false);
  variants.forEach((v, i) => {
    const material = b.material({...v, pbrMetallicRoughness: {baseColorFactor: [0.08, 0.1, 0.15, 1],
                                                              metallicFactor: 0, roughnessFactor: 0.3}});
    b.node({name: v.name, mesh: b.mesh(geometry, material), translation: [(i - 2) * 2.2, 0, 0]});
  });
  return b.glb();
}
