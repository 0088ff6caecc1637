// The side panels for what the session holds: the model (upload, library, built-in), materials,
// and the settings (sun, ambient, exposure, markers, anti-aliasing, technique, animation). Every control shows
// the server's value and every change is a request; the answer is what the control shows next.

import {hexToLinear, linearToHex, splitStrength} from './color.js';
import {PatchSender} from './sender.js';
import {chooseEntry, collectFiles, describeFiles, entryChoices, modelUpload, relativePath,
        uploadProblem} from './upload.js';

const $ = (id) => document.getElementById(id);
const round = (x, digits = 4) => Math.round(x * 10 ** digits) / 10 ** digits;

// Runs `work` with `button` marked busy: aria-busy and aria-disabled (it keeps the keyboard focus,
// which `disabled` would drop), its label saying what goes on, and a second press ignored. The
// result of `work`, or undefined when the button was busy already.
export async function whileBusy(button, label, work) {
  if (button.getAttribute('aria-busy') === 'true') return undefined;
  const text = button.textContent;
  button.setAttribute('aria-busy', 'true');
  button.setAttribute('aria-disabled', 'true');
  if (label) button.textContent = label;
  try {
    return await work();
  } finally {
    button.removeAttribute('aria-busy');
    button.removeAttribute('aria-disabled');
    button.textContent = text;
  }
}

function fillSelect(select, items, selected) {
  select.replaceChildren(...items.map(({value, label}) => {
    const option = document.createElement('option');
    option.value = value;
    option.textContent = label ?? value;
    return option;
  }));
  if (selected !== undefined) select.value = selected;
}

// Model: the source, upload, the --models library, the built-in scene.
export class ModelPanel {
  constructor(api, {onLoaded, onCamera, onProblem, onInfo}) {
    this.api = api;
    this.onLoaded = onLoaded;    // (SessionState) after a model replaced the scene
    this.onCamera = onCamera;    // (Camera) after one of the model's cameras became the camera
    this.onProblem = onProblem;
    this.onInfo = onInfo;        // (text) progress shown to the user
    for (const id of ['model-file', 'model-folder']) {
      const input = $(id);
      input.addEventListener('change', async () => {
        await this.upload([...input.files]);
        input.value = '';  // choosing the same files again loads them again
      });
    }
    $('model-library-load').addEventListener('click', () =>
        whileBusy($('model-library-load'), 'Loading\u2026', () => this.loadLibrary()));
    $('model-builtin').addEventListener('click', () =>
        whileBusy($('model-builtin'), 'Loading\u2026', () => this.load({source: 'builtin:default'})));
    $('model-camera-use').addEventListener('click', () => this.useCamera());
  }

  show(state) {
    const m = state.model;
    const l = m.lights;
    const lights = l && l.point + l.spot + l.directional > 0
        ? `; file lights: ${l.point} point, ${l.spot} spot, ${l.directional} directional` +
          (l.directionalDropped ? ` (${l.directionalDropped} directional not used: at most 3)` : '')
        : '';
    $('model-summary').textContent =
        `${m.source}: ${m.meshes} meshes, ${m.instances} instances, ${m.materials} materials${lights}`;
    // The file's cameras: the perspective ones can become the view (POST .../camera/select).
    const cameras = (m.cameras || []).filter((c) => c.type === 'perspective');
    fillSelect($('model-camera'), cameras.length
        ? cameras.map((c) => ({value: String(c.index),
                               label: `${c.name || 'camera ' + c.index} (${round(c.yfov * 180 / Math.PI, 1)}\u00b0)`}))
        : [{value: '', label: 'none in the file'}]);
    $('model-camera-use').disabled = cameras.length === 0;
  }

  async useCamera() {
    const index = $('model-camera').value;
    if (index === '') return;
    try {
      const camera = await this.api.request('POST', this.api.sessionPath('/camera/select'),
                                            {json: {modelCamera: Number(index)}});
      this.onCamera?.(camera);
    } catch (e) {
      this.onProblem(e);
    }
  }

  async refreshLibrary() {
    try {
      const {models} = await this.api.get('/v1/models');
      const items = models.map((m) => ({value: m.name,
                                         label: `${m.name} (${(m.bytes / 1024).toFixed(0)} KiB)`}));
      fillSelect($('model-library'), items.length ? items
                                                  : [{value: '', label: 'none (no --models)'}]);
      $('model-library-load').disabled = items.length === 0;
    } catch (e) {
      this.onProblem(e);
    }
  }

  // What happens to the lights (?lights=): by default they are generated again around the new
  // model (fit), as many as there were, rather than left where the old model was.
  lightsQuery() {
    return {lights: $('model-lights').value || 'fit'};
  }

  async load(json) {
    this.onInfo(`Loading ${json.source}...`);
    try {
      const state = await this.api.request('PUT', this.api.sessionPath('/model'),
                                           {json, query: this.lightsQuery()});
      this.onInfo(null);
      this.onLoaded(state);
    } catch (e) {
      this.onProblem(e);
    }
  }

  loadLibrary() {
    const name = $('model-library').value;
    if (name) this.load({source: `library:${name}`});
  }

  // One file, several, or a folder: replaces the session's model (PUT .../model). An upload that
  // holds several models asks which one (a dialog), then goes again naming it (?entry=).
  async upload(files, paths = files.map(relativePath), entry = '') {
    if (!files.length) return;
    this.onInfo(`Uploading ${describeFiles(files)}...`);
    const query = {...this.lightsQuery(), ...(entry ? {entry} : {})};
    try {
      const state = await this.api.request('PUT', this.api.sessionPath('/model'),
                                           modelUpload(files, paths, query));
      this.onInfo(null);
      this.onLoaded(state);
    } catch (e) {
      const choices = entry ? [] : entryChoices(e, paths);
      if (choices.length > 1) {
        this.onInfo(null);
        const chosen = await chooseEntry(choices);
        if (chosen) await this.upload(files, paths, chosen);
        return;
      }
      this.onProblem(uploadProblem(e));
    }
  }

  // Files dropped on `element` go to `handle(files, paths, event)` (default: upload, as a pick);
  // dropped folders are walked. A drop without file entries (a page's synthetic DataTransfer)
  // takes its plain file list.
  acceptDrops(element, handle = (files, paths) => this.upload(files, paths)) {
    element.addEventListener('dragover', (event) => event.preventDefault());
    element.addEventListener('drop', async (event) => {
      event.preventDefault();
      const entries = [...event.dataTransfer.items]
          .map((item) => item.webkitGetAsEntry && item.webkitGetAsEntry()).filter(Boolean);
      const found = [];
      for (const entry of entries) await collectFiles(entry, '', found);
      if (!entries.length) {
        for (const file of event.dataTransfer.files) found.push({file, path: file.name});
      }
      if (!found.length) return;
      // A single dropped folder: paths inside it, as its model refers to them.
      const folder = entries.length === 1 && entries[0].isDirectory ? `${entries[0].name}/` : '';
      await handle(found.map((f) => f.file),
                   found.map((f) => f.path.startsWith(folder) ? f.path.slice(folder.length) : f.path),
                   event);
    });
  }
}

// Materials: pick one, edit its glTF factors (base colour and alpha, metallic, roughness,
// emission, normal scale, occlusion strength, alpha mode and cutoff, double-sided); its textures
// are listed (read-only).
const MATERIAL_INPUTS = ['material-color', 'material-metallic', 'material-roughness',
                         'material-alpha', 'material-emissive', 'material-emissive-strength',
                         'material-normal-scale', 'material-occlusion', 'material-alpha-mode',
                         'material-alpha-cutoff', 'material-double-sided'];
export class MaterialPanel {
  constructor(api, {onProblem}) {
    this.api = api;
    this.materials = [];
    this.sender = new PatchSender((patch, end) => this.api.patch(
        this.api.sessionPath(`/materials/${this.current().id}`), patch, end));
    this.sender.onProblem = onProblem;
    this.sender.onAnswer = (material) => this.replace(material);
    this.onProblem = onProblem;

    $('material').addEventListener('change', () => this.showCurrent());
    // A slider or colour released: its still at once (PatchSender.end).
    for (const id of ['material-color', 'material-metallic', 'material-roughness', 'material-alpha',
                      'material-emissive', 'material-normal-scale', 'material-occlusion',
                      'material-alpha-cutoff']) {
      $(id).addEventListener('change', () => { if (this.current()) this.sender.end(); });
    }
    $('material-color').addEventListener('input', (e) =>
        this.edit({baseColor: hexToLinear(e.target.value)}));
    $('material-metallic').addEventListener('input', (e) =>
        this.edit({metallic: Number(e.target.value)}));
    $('material-roughness').addEventListener('input', (e) =>
        this.edit({roughness: Number(e.target.value)}));
    $('material-alpha').addEventListener('input', (e) => this.edit({alpha: Number(e.target.value)}));
    $('material-emissive').addEventListener('input', (e) =>
        this.edit({emissive: hexToLinear(e.target.value)}));
    $('material-emissive-strength').addEventListener('change', (e) => {
      const value = Number(e.target.value);
      if (Number.isFinite(value) && value >= 0 && value <= 10000) this.edit({emissiveStrength: value});
    });
    $('material-normal-scale').addEventListener('input', (e) =>
        this.edit({normalScale: Number(e.target.value)}));
    $('material-occlusion').addEventListener('input', (e) =>
        this.edit({occlusionStrength: Number(e.target.value)}));
    $('material-alpha-mode').addEventListener('change', (e) => this.edit({alphaMode: e.target.value}));
    $('material-alpha-cutoff').addEventListener('input', (e) =>
        this.edit({alphaCutoff: Number(e.target.value)}));
    $('material-double-sided').addEventListener('change', (e) =>
        this.edit({doubleSided: e.target.checked}));
  }

  current() {
    return this.materials.find((m) => String(m.id) === $('material').value);
  }

  async refresh() {
    try {
      const {materials} = await this.api.get(this.api.sessionPath('/materials'));
      const keep = $('material').value;
      this.materials = materials;
      fillSelect($('material'), materials.map((m) => ({value: String(m.id),
                                                       label: `${m.id}: ${m.name || '(unnamed)'}`})));
      if (materials.some((m) => String(m.id) === keep)) $('material').value = keep;
      this.showCurrent();
    } catch (e) {
      this.onProblem(e);
    }
  }

  showCurrent() {
    const m = this.current();
    for (const id of MATERIAL_INPUTS) $(id).disabled = !m;
    const list = $('material-textures');
    list.replaceChildren();
    if (!m) return;
    $('material-color').value = linearToHex(m.baseColor);
    $('material-metallic').value = m.metallic;
    $('material-roughness').value = m.roughness;
    $('material-alpha').value = m.alpha;
    $('material-emissive').value = linearToHex(m.emissive);
    $('material-emissive-strength').value = m.emissiveStrength;
    // The slider spans 0..2, widened to show a file's value outside it (the API allows +-100).
    $('material-normal-scale').min = Math.min(0, m.normalScale);
    $('material-normal-scale').max = Math.max(2, m.normalScale);
    $('material-normal-scale').value = m.normalScale;
    $('material-occlusion').value = m.occlusionStrength;
    $('material-alpha-mode').value = m.alphaMode;
    $('material-alpha-cutoff').value = m.alphaCutoff;
    $('material-double-sided').checked = m.doubleSided;
    // Text nodes only: image names come from the uploaded file.
    for (const t of m.textures) {
      const item = document.createElement('li');
      item.dataset.slot = t.slot;
      item.textContent = `${t.slot}: ${t.image} (${t.width} x ${t.height}, ` +
          `${t.wrapS}/${t.wrapT}, ${t.magFilter}/${t.minFilter}${t.mipmaps ? ', mipmaps' : ''})`;
      list.append(item);
    }
    if (!m.textures.length) {
      const item = document.createElement('li');
      item.textContent = 'no textures';
      list.append(item);
    }
  }

  edit(patch) {
    if (this.current()) this.sender.queue(patch);
  }

  replace(material) {
    const i = this.materials.findIndex((m) => m.id === material.id);
    if (i >= 0) this.materials[i] = material;
    if (this.current()?.id === material.id && !this.sender.busy) this.showCurrent();
  }
}

// Settings: sun (as azimuth and elevation of the direction towards the sun), its colour and
// intensity, ambient, exposure, fog, markers, technique, animation, and the environment light.
export class SettingsPanel {
  constructor(api, {onProblem, onChange}) {
    this.api = api;
    this.settings = null;
    this.sunColorStrength = 1;
    this.onChange = onChange;  // (Settings) after the server answered
    this.sender = new PatchSender((patch, end) =>
        this.api.patch(this.api.sessionPath('/settings'), patch, end));
    this.sender.onProblem = onProblem;
    this.sender.onAnswer = (settings) => this.show(settings);
    this.onProblem = onProblem;

    const sunDirection = () => {
      const az = (Number($('sun-azimuth').value) * Math.PI) / 180;
      const el = (Number($('sun-elevation').value) * Math.PI) / 180;
      // The API's direction is the way the light travels: from the sun, so the negated vector.
      return [-Math.cos(el) * Math.sin(az), -Math.sin(el), -Math.cos(el) * Math.cos(az)].map(
          (c) => round(c, 5));
    };
    // A slider or colour released: its still at once (PatchSender.end).
    for (const id of ['sun-azimuth', 'sun-elevation', 'sun-color', 'sun-intensity', 'ambient-color',
                      'ambient-strength', 'exposure', 'fog-density', 'fog-color', 'env-intensity',
                      'env-rotation']) {
      $(id).addEventListener('change', () => this.sender.end());
    }
    $('sun-azimuth').addEventListener('input', () => this.edit({sun: {direction: sunDirection()}}));
    $('sun-elevation').addEventListener('input', () => this.edit({sun: {direction: sunDirection()}}));
    // The picker shows the sun colour's hue; its strength above 1 (colours go to 64) is kept.
    $('sun-color').addEventListener('input', (e) => this.edit({sun: {color:
        hexToLinear(e.target.value).map((c) => round(c * this.sunColorStrength))}}));
    $('sun-intensity').addEventListener('input', (e) =>
        this.edit({sun: {intensity: Number(e.target.value)}}));
    const ambient = () => {
      const strength = Number($('ambient-strength').value);
      return hexToLinear($('ambient-color').value).map((c) => round(c * strength));
    };
    $('ambient-color').addEventListener('input', () => this.edit({ambient: ambient()}));
    $('ambient-strength').addEventListener('input', () => this.edit({ambient: ambient()}));
    $('exposure').addEventListener('input', (e) =>
        this.edit({exposure: round(2 ** Number(e.target.value))}));
    $('fog-density').addEventListener('input', (e) =>
        this.edit({fog: {density: Number(e.target.value)}}));
    $('fog-color').addEventListener('input', (e) =>
        this.edit({fog: {color: hexToLinear(e.target.value)}}));
    $('markers').addEventListener('change', (e) => this.edit({markers: e.target.checked}));
    $('sun-shadows').addEventListener('change', (e) => this.edit({shadows: {sun: e.target.checked}}));
    $('shadow-map-size').addEventListener('change', (e) =>
        this.edit({shadows: {mapSize: Number(e.target.value)}}));
    $('local-shadows').addEventListener('change', (e) =>
        this.edit({shadows: {local: e.target.value}}));
    $('antialias').addEventListener('change', (e) => this.edit({antialias: e.target.value}));
    $('animate').addEventListener('change', (e) => this.edit({animate: e.target.checked}));
    $('technique').addEventListener('change', (e) => this.edit({technique: e.target.value}));
    // The environment light: mode, intensity, rotation (degrees here, radians on the wire),
    // background, and an .hdr upload (PUT .../environment, which selects mode hdr).
    $('env-mode').addEventListener('change', (e) => this.edit({environment: {mode: e.target.value}}));
    $('env-intensity').addEventListener('input', (e) =>
        this.edit({environment: {intensity: Number(e.target.value)}}));
    $('env-rotation').addEventListener('input', (e) =>
        this.edit({environment: {rotation: round((Number(e.target.value) * Math.PI) / 180, 5)}}));
    $('env-background').addEventListener('change', (e) =>
        this.edit({environment: {background: e.target.checked}}));
    $('env-file').addEventListener('change', async () => {
      const file = $('env-file').files[0];
      if (!file) return;
      try {
        this.show(await this.api.request('PUT', this.api.sessionPath('/environment'), {
          body: file, query: {filename: file.name}, contentType: 'image/vnd.radiance'}));
      } catch (e) {
        this.onProblem(e);
      }
      $('env-file').value = '';  // choosing the same file again uploads it again
    });
  }

  setTechniques(techniques) {
    fillSelect($('technique'), techniques.map((t) => ({value: t})));
  }

  // Stochastic shadows trace a ray a pixel through the scene's BVH in compute: cheap on a GPU,
  // seconds a frame on a CPU renderer, so the page offers them only where the device is a GPU
  // and says why not elsewhere (the API still takes them: a batch job may wait).
  setDevice(device) {
    this.gpu = device?.isCpu === false;
    const option = $('local-shadows').querySelector('option[value="stochastic"]');
    option.disabled = !this.gpu;
    option.textContent = this.gpu ? 'stochastic (every light)' : 'stochastic (every light; needs a GPU)';
    this.showShadowCost();
  }

  // What the local shadows cost, from the last frame's passes (GET .../stats, StatsPanel).
  showShadowCost(frame = this.lastFrame) {
    this.lastFrame = frame;
    const local = this.settings?.shadows?.local;
    const passMs = (name) => frame?.passes?.find((p) => p.name === name)?.ms;
    let text;
    if (local === 'stochastic') {
      const rays = passMs('shadow-rays');
      const bvh = passMs('bvh-build') ?? passMs('bvh-refit');
      text = rays === undefined
          ? 'Every light shadowed: one shadow ray a pixel (noisy: no denoiser yet).'
          : `Every light shadowed: the shadow rays took ${rays.toFixed(2)} ms` +
            (bvh === undefined ? '' : ` and the BVH ${bvh.toFixed(2)} ms`) +
            ` of the last ${frame.width}\u00d7${frame.height} frame (one ray a pixel: noisy, no denoiser yet).`;
    } else if (this.gpu === false) {
      text = 'Stochastic shadows (every light) need a GPU: on this CPU renderer a frame takes seconds.';
    } else {
      text = local === 'maps' ? 'Shadow maps for the 16 most important lights; the rest unshadowed.'
                              : local === 'none' ? 'Local lights unshadowed.' : '';
    }
    if ($('local-shadows-cost').textContent !== text) $('local-shadows-cost').textContent = text;
  }

  async refresh() {
    try {
      this.show(await this.api.get(this.api.sessionPath('/settings')));
    } catch (e) {
      this.onProblem(e);
    }
  }

  edit(patch) {
    this.sender.queue(patch);
  }

  toggleMarkers() {
    if (this.settings) this.edit({markers: !this.settings.markers});
  }

  // Shows the server's values; a control being dragged keeps its own until its patch landed.
  show(s) {
    this.settings = s;
    this.onChange(s);
    if (this.sender.busy) return;
    const toSun = s.sun.direction.map((c) => -c);
    $('sun-elevation').value = (Math.asin(Math.max(-1, Math.min(1, toSun[1]))) * 180) / Math.PI;
    $('sun-azimuth').value = (Math.atan2(toSun[0], toSun[2]) * 180) / Math.PI;
    const sun = splitStrength(s.sun.color);
    $('sun-color').value = linearToHex(sun.hue);
    this.sunColorStrength = sun.strength || 1;
    $('sun-intensity').max = Math.max(20, s.sun.intensity);
    $('sun-intensity').value = s.sun.intensity;
    const ambient = splitStrength(s.ambient);
    $('ambient-color').value = linearToHex(ambient.hue);
    $('ambient-strength').max = Math.max(1, ambient.strength);
    $('ambient-strength').value = ambient.strength;
    $('exposure').value = Math.log2(s.exposure);
    if (s.fog) {
      $('fog-density').max = Math.max(0.2, s.fog.density);
      $('fog-density').value = s.fog.density;
      $('fog-color').value = linearToHex(s.fog.color.map((c) => Math.min(c, 1)));
    }
    $('markers').checked = s.markers;
    $('sun-shadows').checked = s.shadows?.sun === true;
    $('sun-shadows').disabled = !s.shadows;
    if (s.shadows?.mapSize) $('shadow-map-size').value = String(s.shadows.mapSize);
    $('shadow-map-size').disabled = !s.shadows?.sun;
    $('local-shadows').value = s.shadows?.local || 'maps';
    $('local-shadows').disabled = !s.shadows?.local;
    this.showShadowCost();
    $('antialias').value = s.antialias || 'fxaa';
    $('animate').checked = s.animate;
    $('technique').value = s.technique;
    const env = s.environment;
    $('env-mode').value = env.mode;
    $('env-intensity').max = Math.max(4, env.intensity);
    $('env-intensity').value = env.intensity;
    $('env-rotation').value = (env.rotation * 180) / Math.PI;
    $('env-background').checked = env.background;
    $('env-summary').textContent =
        `${env.mode} \u00d7${round(env.intensity, 3)}, rotation ${round(env.rotation, 3)} rad` +
        `${env.background ? ', shown as background' : ''}${env.source ? `; ${env.source}` : ''}`;
    $('settings-summary').textContent =
        `sun ${fmt(s.sun.direction)} \u00d7${round(s.sun.intensity, 3)}, ` +
        `ambient ${fmt(s.ambient)}, exposure ${round(s.exposure, 3)}`;
  }
}

export function fmt(v) {
  return `[${v.map((c) => round(c, 3)).join(', ')}]`;
}
