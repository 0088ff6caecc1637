// Runs in the browser: renders one case with three.js into a float render target and hands back
// the linear radiance (no tone mapping, no output colour space: render targets get neither).
//
// mode 'stock': three.js as shipped. mode 'spec': three.js with its punctual-light BRDF made the
// glTF 2.0 specification's (Appendix B) and the spot cone made KHR_lights_punctual's recommended
// one, by the replacements in SPEC_PATCHES; each must apply exactly once, so a three.js update that
// changes these chunks fails loudly instead of silently comparing something else.

import * as THREE from 'three';
import {GLTFLoader} from 'three/addons/loaders/GLTFLoader.js';

// [chunk, text, replacement, occurrences]; whitespace runs in `text` match any whitespace (the
// built three.module.js keeps the chunks without blank lines and comments).
const SPEC_PATCHES = [
  // Separable Smith-GGX visibility (glTF Appendix B) instead of the height-correlated one.
  ['lights_physical_pars_fragment',
   `float gv = dotNL * sqrt( a2 + ( 1.0 - a2 ) * pow2( dotNV ) );
    float gl = dotNV * sqrt( a2 + ( 1.0 - a2 ) * pow2( dotNL ) );
    return 0.5 / max( gv + gl, EPSILON );`,
   `float gv = dotNV + sqrt( a2 + ( 1.0 - a2 ) * pow2( dotNV ) );
    float gl = dotNL + sqrt( a2 + ( 1.0 - a2 ) * pow2( dotNL ) );
    return 1.0 / max( gv * gl, EPSILON );`, 1],
  // No multiple-scattering energy compensation on direct light (the spec's BRDF has none).
  ['lights_fragment_begin',
   'material.multiScatteringCompensation = 1.0 + material.specularColorBlended * ( 1.0 / EssMs - 1.0 );',
   'material.multiScatteringCompensation = vec3( 1.0 );', 1],
  // The spec's fresnel_mix: the diffuse layer loses F of the blended F0 (three.js: dielectric F0).
  ['lights_physical_pars_fragment',
   'vec3 F = F_Schlick( material.specularColor, material.specularF90, dotVH );',
   'vec3 F = F_Schlick( material.specularColorBlended, material.specularF90, dotVH );', 1],
  // Schlick's Fresnel with the power of five, not the spherical-Gaussian approximation (both
  // overloads).
  ['common',
   'float fresnel = exp2( ( - 5.55473 * dotVH - 6.98316 ) * dotVH );',
   'float fresnel = pow( 1.0 - dotVH, 5.0 );', 2],
  // No roughness added from screen-space normal derivatives (specular anti-aliasing).
  ['lights_physical_fragment',
   'float geometryRoughness = max( max( dxy.x, dxy.y ), dxy.z );',
   'float geometryRoughness = 0.0;', 1],
  // KHR_materials_clearcoat's clearcoat_fresnel: Schlick's at N.V for the coat's own lobe too
  // (three.js takes V.H there and N.V only for what the layers below lose).
  ['lights_physical_pars_fragment',
   `vec3 F = F_Schlick( f0, f90, dotVH );
    float V = V_GGX_SmithCorrelated( alpha, dotNL, dotNV );
    float D = D_GGX( alpha, dotNH );
    return F * ( V * D );`,
   `vec3 F = F_Schlick( f0, f90, dotNV );
    float V = V_GGX_SmithCorrelated( alpha, dotNL, dotNV );
    float D = D_GGX( alpha, dotNH );
    return F * ( V * D );`, 1],
  // KHR_lights_punctual's recommended cone falloff: t = linear step between the cosines, t^2.
  ['lights_pars_begin',
   'return smoothstep( coneCosine, penumbraCosine, angleCosine );',
   'float t = saturate( ( angleCosine - coneCosine ) / max( penumbraCosine - coneCosine, 0.001 ) ); return t * t;', 1],
];

function applySpecPatches() {
  for (const [chunk, text, replacement, occurrences] of SPEC_PATCHES) {
    const pattern = new RegExp(text.trim().replace(/[.*+?^${}()|[\]\\]/g, '\\$&').replace(/\s+/g, '\\s+'), 'g');
    const found = (THREE.ShaderChunk[chunk].match(pattern) || []).length;
    if (found !== occurrences) {
      throw new Error(`three.js r${THREE.REVISION}: the spec patch of ShaderChunk.${chunk} matches ` +
                      `${found} times, not ${occurrences}: ${text.slice(0, 70)}...`);
    }
    THREE.ShaderChunk[chunk] = THREE.ShaderChunk[chunk].replace(pattern, replacement);
  }
}

const mode = new URL(location.href).searchParams.get('mode') || 'stock';
if (mode === 'spec') applySpecPatches();

const canvas = document.createElement('canvas');
document.body.appendChild(canvas);
const renderer = new THREE.WebGLRenderer({canvas, antialias: false});
renderer.setPixelRatio(1);
renderer.toneMapping = THREE.NoToneMapping;
renderer.shadowMap.enabled = false;

// spec: {model: URL, width, height, camera: {eye, target, up, fovY, near, far},
//        sun: {direction, color, intensity} | null, lights: [{type: 'point'|'spot', position,
//        direction, color, intensity, range, innerConeAngle, outerConeAngle}], anisotropy}.
// Returns {rgba: base64 of Float32 RGBA rows top first, lights: what the file's lights became}.
async function renderCase(spec) {
  const gltf = await new GLTFLoader().loadAsync(spec.model);
  const scene = new THREE.Scene();
  scene.background = null;
  scene.add(gltf.scene);
  // spec.time: the file's first animation clip at that time (looped, as Myriad plays it), posed
  // before rendering; skinned and morphed meshes are not culled by their rest bounds. Deliberate
  // errors (perturb): timeOffset seconds later; stepAsLinear: STEP samplers interpolated.
  if (spec.time !== undefined && gltf.animations.length) {
    const clip = gltf.animations[0];
    if (spec.perturb?.stepAsLinear) {
      for (const track of clip.tracks) {
        if (track.getInterpolation() === THREE.InterpolateDiscrete) track.setInterpolation(THREE.InterpolateLinear);
      }
    }
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(clip).play();
    mixer.setTime(spec.time + (spec.perturb?.timeOffset ?? 0));
    gltf.scene.traverse((o) => { if (o.isMesh) o.frustumCulled = false; });
  }
  // A deliberate error (the judge's sensitivity check): {light: scale of every light's intensity,
  // sunDegrees: the sun turned about the vertical, roughness: scale of every roughness, fovY:
  // degrees added, range: scale of every light's range, coneRadians: added to every spot's outer
  // cone (the inner one kept), normalScale: scale of every normal map's x and y (-1: bumps become
  // dents, as a flipped tangent frame makes them), opacity: scale of every transparent (BLEND)
  // material's opacity, fileOrder: transparent surfaces drawn in the file's order, not sorted,
  // emissiveStrength: 0 for KHR_materials_emissive_strength ignored (intensity 1), noTextureTransform:
  // every map's KHR_texture_transform ignored, iorSpecular: false for KHR_materials_ior and
  // _specular ignored, clearcoat: false for KHR_materials_clearcoat ignored, sheen: false for
  // KHR_materials_sheen ignored}.
  const perturb = {light: 1, sunDegrees: 0, roughness: 1, fovY: 0, range: 1, coneRadians: 0, normalScale: 1,
                   opacity: 1, fileOrder: false, ...(spec.perturb || {})};
  let order = 0;
  scene.traverse((o) => {
    if (o.material && perturb.roughness !== 1) o.material.roughness = Math.min(1, o.material.roughness * perturb.roughness);
    if (o.material?.normalMap && perturb.normalScale !== 1) o.material.normalScale.multiplyScalar(perturb.normalScale);
    if (o.material?.transparent && perturb.opacity !== 1) o.material.opacity = Math.min(1, o.material.opacity * perturb.opacity);
    if (o.isMesh && perturb.fileOrder) o.renderOrder = order++;  // draw in the file's order, unsorted
    if (o.material && perturb.emissiveStrength === 0) o.material.emissiveIntensity = 1;
    if (o.material?.isMeshPhysicalMaterial && perturb.clearcoat === false) o.material.clearcoat = 0;
    if (o.material?.isMeshPhysicalMaterial && perturb.sheen === false) o.material.sheen = 0;
    if (o.material?.isMeshPhysicalMaterial && perturb.iorSpecular === false) {
      o.material.ior = 1.5;
      o.material.specularIntensity = 1;
    }
    for (const key of ['map', 'normalMap', 'roughnessMap', 'metalnessMap', 'emissiveMap', 'aoMap']) {
      const t = o.material?.[key];
      if (t && perturb.noTextureTransform) {
        t.offset.set(0, 0);
        t.repeat.set(1, 1);
        t.rotation = 0;
        t.matrixAutoUpdate = true;  // GLTFLoader sets the matrix itself where there is a rotation
      }
    }
  });
  // Texture filtering as Myriad samples (the glTF leaves anisotropy to the renderer): spec.anisotropy
  // (Myriad's, from its device: 16x anisotropic on a GPU where the sampler is linear and mipmapped,
  // none on a CPU implementation) instead of three.js's default 1x.
  const anisotropy = Math.min(spec.anisotropy, renderer.capabilities.getMaxAnisotropy());
  scene.traverse((o) => {
    for (const key of ['map', 'normalMap', 'roughnessMap', 'metalnessMap', 'emissiveMap', 'aoMap']) {
      const t = o.material?.[key];
      const mipmappedLinear = [THREE.LinearMipmapLinearFilter, THREE.LinearMipmapNearestFilter];
      if (t && mipmappedLinear.includes(t.minFilter)) t.anisotropy = anisotropy;
    }
  });

  if (spec.sun && spec.sun.intensity > 0) {
    const sun = new THREE.DirectionalLight(new THREE.Color(...spec.sun.color), spec.sun.intensity);
    const d = new THREE.Vector3(...spec.sun.direction).normalize()
                  .applyAxisAngle(new THREE.Vector3(0, 1, 0), THREE.MathUtils.degToRad(perturb.sunDegrees));
    sun.position.copy(d.clone().multiplyScalar(-10));  // light travels from position to target
    sun.target.position.set(0, 0, 0);
    scene.add(sun, sun.target);
  }
  for (const l of spec.lights || []) {
    const color = new THREE.Color(...l.color);
    let light;
    if (l.type === 'spot') {
      light = new THREE.SpotLight(color, l.intensity, l.range, l.outerConeAngle,
                                  1 - l.innerConeAngle / l.outerConeAngle, 2);
      light.target.position.set(l.position[0] + l.direction[0], l.position[1] + l.direction[1],
                                l.position[2] + l.direction[2]);
      scene.add(light.target);
    } else {
      light = new THREE.PointLight(color, l.intensity, l.range, 2);
    }
    light.position.set(...l.position);
    scene.add(light);
  }

  scene.traverse((o) => {
    if (o.isLight) o.intensity *= perturb.light;
    if (o.isLight && o.distance > 0) o.distance *= perturb.range;
    if (o.isSpotLight && perturb.coneRadians) {
      const inner = o.angle * (1 - o.penumbra);
      o.angle += perturb.coneRadians;
      o.penumbra = 1 - inner / o.angle;
    }
  });

  const c = spec.camera;
  const camera = new THREE.PerspectiveCamera(c.fovY + perturb.fovY, spec.width / spec.height, c.near, c.far);
  camera.position.set(...c.eye);
  camera.up.set(...c.up);
  camera.lookAt(new THREE.Vector3(...c.target));
  camera.updateProjectionMatrix();

  const target = new THREE.WebGLRenderTarget(spec.width, spec.height, {
    type: THREE.FloatType, format: THREE.RGBAFormat, depthBuffer: true, samples: 0,
    minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter});
  renderer.setSize(spec.width, spec.height, false);
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, camera);
  const pixels = new Float32Array(spec.width * spec.height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, spec.width, spec.height, pixels);
  renderer.setRenderTarget(null);
  target.dispose();

  // WebGL reads rows bottom first; flip to top first like Myriad's raw output.
  const flipped = new Float32Array(pixels.length);
  const row = spec.width * 4;
  for (let y = 0; y < spec.height; ++y) {
    flipped.set(pixels.subarray((spec.height - 1 - y) * row, (spec.height - y) * row), y * row);
  }
  const lights = [];
  scene.traverse((o) => {
    if (o.isLight) lights.push({type: o.type, intensity: o.intensity, distance: o.distance});
  });
  scene.traverse((o) => {
    o.geometry?.dispose();
    o.material?.dispose?.();
  });
  const bytes = new Uint8Array(flipped.buffer);
  let binary = '';
  for (let i = 0; i < bytes.length; i += 0x8000) {
    binary += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  }
  const gl = renderer.getContext();
  const debug = gl.getExtension('WEBGL_debug_renderer_info');
  return {rgba: btoa(binary), lights, revision: THREE.REVISION,
          renderer: gl.getParameter(debug ? debug.UNMASKED_RENDERER_WEBGL : gl.RENDERER)};
}

window.renderCase = renderCase;
window.judgeReady = true;
