// The outliner: the session's objects (each one placement of an asset, GET .../objects) and its
// assets (GET .../assets). An object can be selected, shown or hidden, moved, turned and scaled
// (its transform: translation, rotation as Euler degrees, scale) and deleted; an asset no object
// uses can be deleted. A model file added here (or dropped on the view) becomes a new asset and
// a new object at the view's centre, the camera's target; the scene around it stays. An object of
// an asset with animation clips plays one of them (or none) on the scene clock, looped or not.

import {describeFiles, modelUpload, relativePath} from './upload.js';
import {eulerToQuat, transformParts} from './vec.js';

const $ = (id) => document.getElementById(id);
const PAGE_LIMIT = 1000;  // the most objects one GET .../objects answers
const AXES = ['x', 'y', 'z'];
// The editor's fields: id prefix + axis (object-tx, object-ry, ...) for each part of a transform.
const FIELDS = {translation: 'object-t', euler: 'object-r', scale: 'object-s'};
const round = (x) => +x.toFixed(4);

function removeButton(label, onClick) {
  const button = document.createElement('button');
  button.type = 'button';
  button.className = 'remove';
  button.textContent = '\u2715';
  button.title = label;
  button.setAttribute('aria-label', label);
  button.addEventListener('click', onClick);
  return button;
}

export class ObjectsPanel {
  constructor(api, {onProblem, onInfo, onAssetsChanged, onCount = () => {}, onSelected = () => {},
                     onAnimationsChanged = () => {}}) {
    this.api = api;
    this.onCount = onCount;                  // (objects in the scene) after each refresh
    this.onSelected = onSelected;            // (the selected object or null) whenever it is shown
    // () after a refresh or a clip edit: what the scene clock plays may have changed.
    this.onAnimationsChanged = onAnimationsChanged;
    this.onProblem = onProblem;
    this.onInfo = onInfo;                    // (text) progress shown to the user
    this.onAssetsChanged = onAssetsChanged;  // () after an asset (and its materials) came or went
    this.objects = [];
    this.total = 0;
    this.assets = [];
    this.selected = null;  // the selected object's id
    this.parts = null;     // a transform in the fields: {translation, rotation, scale, euler}
    this.partsOf = null;   // ... of this object
    this.pending = 0;      // transform edits not answered yet
    this.edits = Promise.resolve();  // the last of them: they go one at a time, in order

    $('object-file').addEventListener('change', async () => {
      const input = $('object-file');
      await this.addModel([...input.files]);
      input.value = '';  // choosing the same file again adds it again
    });
    $('objects-refresh').addEventListener('click', () => this.refresh());
    $('object-editor').addEventListener('submit', (e) => e.preventDefault());
    for (const [part, prefix] of Object.entries(FIELDS)) {
      for (const axis of AXES) {
        $(prefix + axis).addEventListener('change', () => this.editTransform(part, axis));
      }
    }
    $('object-delete').addEventListener('click', () => this.deleteObject(this.selected));
    $('object-clip').addEventListener('change', () => this.editAnimation());
    $('object-loop').addEventListener('change', () => this.editAnimation());
  }

  async refresh() {
    try {
      const [page, {assets}] = await Promise.all([
        this.api.get(this.api.sessionPath('/objects'), {query: {limit: PAGE_LIMIT}}),
        this.api.get(this.api.sessionPath('/assets'))]);
      this.objects = page.objects;
      this.total = page.total;
      this.assets = assets;
      this.onCount(this.total);
      if (!this.objects.some((o) => o.id === this.selected)) this.selected = null;
      this.render();
      this.showEditor();
      this.onAnimationsChanged();
    } catch (e) {
      this.onProblem(e);
    }
  }

  // Files (a model, a .zip, or a model with its files) as a new object at the camera's target.
  async addModel(files, paths = files.map(relativePath)) {
    if (!files.length) return;
    this.onInfo(`Adding ${describeFiles(files)} to the scene...`);
    try {
      const asset = await this.api.request('POST', this.api.sessionPath('/assets'),
                                           modelUpload(files, paths));
      const camera = await this.api.get(this.api.sessionPath('/camera'));
      const {ids} = await this.api.post(this.api.sessionPath('/objects'), {
        objects: [{asset: asset.id, transform: {translation: camera.target}}]});
      this.onInfo(null);
      this.selected = ids[0];
      this.onAssetsChanged();
      await this.refresh();
    } catch (e) {
      this.onProblem(e);
    }
  }

  render() {
    const byId = new Map(this.objects.map((o) => [o.id, o]));
    const depth = (o) => {
      let d = 0;
      for (let p = o.parent; p && byId.has(p) && d < 16; p = byId.get(p).parent) ++d;
      return d;
    };
    const shown = this.objects.length < this.total ? ` (the first ${this.objects.length} listed)` : '';
    $('objects-summary').textContent =
        `${this.total} objects${shown}, ${this.assets.length} assets`;
    $('object-list').replaceChildren(...this.objects.map((o) => {
      const item = document.createElement('li');
      item.dataset.id = o.id;
      item.classList.toggle('selected', o.id === this.selected);
      item.style.paddingLeft = `${4 + 12 * depth(o)}px`;
      const visible = document.createElement('input');
      visible.type = 'checkbox';
      visible.checked = o.visible;
      visible.title = 'Shown';
      visible.setAttribute('aria-label', `Show object ${o.id}`);
      visible.addEventListener('change', () => this.setVisible(o.id, visible.checked));
      const name = document.createElement('button');
      name.type = 'button';
      name.className = 'name';
      name.textContent = `#${o.id} ${o.name}`;
      name.title = `${o.asset}: ${o.instances} instances drawn`;
      name.setAttribute('aria-pressed', String(o.id === this.selected));
      name.addEventListener('click', () => this.select(o.id));
      item.append(visible, name, removeButton(`Delete object ${o.id}`, () => this.deleteObject(o.id)));
      return item;
    }));
    $('asset-list').replaceChildren(...this.assets.map((a) => {
      const item = document.createElement('li');
      item.dataset.id = a.id;
      const name = document.createElement('span');
      name.className = 'name';
      name.textContent = a.source;
      name.title = `${a.id}: ${a.meshes} meshes, ${a.instances} instances, ` +
                   `${a.materials.count} materials, ${a.images} images`;
      const users = document.createElement('span');
      users.className = 'muted';
      users.dataset.objects = a.objects;
      users.textContent = `${a.objects} object${a.objects === 1 ? '' : 's'}`;
      item.append(name, users, removeButton(`Delete asset ${a.source}`, () => this.deleteAsset(a.id)));
      return item;
    }));
  }

  // The selected object's name again unselects it (a toggle, as its aria-pressed says).
  select(id) {
    this.selected = id === this.selected ? null : id;
    this.render();
    this.showEditor();
  }

  // The selected object's transform in the fields (unless an edit of it is on its way). The field
  // being typed in keeps what it has (it is sent once left), unless `all` (a refused edit).
  showEditor(all = false) {
    const o = this.objects.find((x) => x.id === this.selected);
    $('object-editor').hidden = !o;
    this.onSelected(o || null);
    if (!o || this.pending) return;
    $('object-editor-title').textContent = `Object #${o.id}: ${o.name}`;
    this.parts = transformParts(o.transform);
    this.baseTransform = o.transform;  // what the fields show, as the server sent it
    this.partsOf = o.id;
    for (const [part, prefix] of Object.entries(FIELDS)) {
      AXES.forEach((axis, i) => {
        const field = $(prefix + axis);
        if (all || field !== document.activeElement) field.value = round(this.parts[part][i]);
      });
    }
    const [sx, sy, sz] = this.parts.scale;
    $('object-scale-uniform').checked = sx === sy && sy === sz;
    this.showAnimation(o.animation);
  }

  // The clip choice, for an object whose asset has clips: none (the rest pose) or one by index
  // (the API names only the one playing).
  showAnimation(animation) {
    const clips = Math.min(animation?.clips || 0, 1024);
    $('object-animation').hidden = clips === 0;
    if (!clips) return;
    const choices = [new Option('none (rest pose)', '')];
    for (let i = 0; i < clips; ++i) {
      const playing = i === animation.clip;
      const name = playing && animation.clipName ? ` ${animation.clipName}` : '';
      const length = playing && animation.duration !== undefined
          ? ` (${round(animation.duration)} s)` : '';
      choices.push(new Option(`${i}${name}${length}`, String(i)));
    }
    $('object-clip').replaceChildren(...choices);
    $('object-clip').value = animation.clip === null ? '' : String(animation.clip);
    $('object-loop').checked = animation.loop !== false;
  }

  async editAnimation() {
    const id = this.selected;
    if (!id || this.partsOf !== id) return;
    const clip = $('object-clip').value;
    const animation = {clip: clip === '' ? null : Number(clip), loop: $('object-loop').checked};
    try {
      this.replace(await this.api.patch(this.api.sessionPath(`/objects/${id}`), {animation}, true));
    } catch (e) {
      this.onProblem(e);
      this.showEditor(true);
    }
    this.onAnimationsChanged();
  }

  // One field changed: that part of the transform from the fields, the others as they are (a
  // matrix becomes translation, rotation and scale). PATCH replaces the whole transform.
  async editTransform(part, axis) {
    const id = this.selected;
    if (!id || this.partsOf !== id) return;  // the fields show another object still
    if (part === 'scale' && $('object-scale-uniform').checked) {
      for (const other of AXES) $(FIELDS.scale + other).value = $(FIELDS.scale + axis).value;
    }
    const values = AXES.map((a) => $(FIELDS[part] + a).valueAsNumber);
    if (!values.every(Number.isFinite)) {
      this.onProblem(new Error(`The object's ${part === 'euler' ? 'rotation' : part} needs three numbers.`));
      return;
    }
    if (part === 'euler') this.parts.rotation = eulerToQuat(values);
    this.parts[part] = values;
    const {translation, rotation, scale} = this.parts;
    ++this.pending;
    // After the edits before it: requests in parallel may land in any order, and the last one
    // typed must be the one that stays.
    this.edits = this.edits.then(async () => {
      try {
        // Over the transform the fields were made from: the server's, as the editor last showed
        // it or as the edit before this one left it.
        const object = await this.patchTransform(id, this.baseTransform,
                                                 {translation, rotation, scale});
        this.baseTransform = object.transform;
        this.replace(object);
        --this.pending;
        this.showEditor();
      } catch (e) {
        --this.pending;
        this.onProblem(e);
        this.showEditor(true);  // back to the server's values
      }
    });
    await this.edits;
  }

  // The whole transform, but only over the one the editor showed (api.patchIfUnchanged): a
  // transform changed elsewhere meanwhile (another page, a script, an event not yet seen here)
  // stops the edit, which says so (the fields then show the object as it is). The object as the
  // server has it.
  async patchTransform(id, shown, transform) {
    const {conflict, updated} = await this.api.patchIfUnchanged(
        this.api.sessionPath(`/objects/${id}`), {transform},
        (current) => !shown || JSON.stringify(current.transform) === JSON.stringify(shown),
        {headers: {'X-Myriad-Interaction': 'end'}});
    if (conflict) {
      this.replace(conflict);
      throw new Error(`Object #${id} was moved elsewhere while you edited it: your change was ` +
                      'not applied; the fields show the object as it is now.');
    }
    return updated;
  }

  async setVisible(id, visible) {
    try {
      this.replace(await this.api.patch(this.api.sessionPath(`/objects/${id}`), {visible}, true));
    } catch (e) {
      this.onProblem(e);
      this.render();  // the box as it was
    }
  }

  replace(object) {
    const i = this.objects.findIndex((o) => o.id === object.id);
    if (i >= 0) this.objects[i] = object;
    this.render();
    this.showEditor();
  }

  // Deleting an object deletes its children too; the asset stays.
  async deleteObject(id) {
    if (!id) return;
    try {
      await this.api.delete(this.api.sessionPath(`/objects/${id}`));
      if (this.selected === id) this.selected = null;
    } catch (e) {
      this.onProblem(e);
    }
    await this.refresh();
  }

  // Refused (409, its detail shown) while an object draws the asset or one of its materials.
  async deleteAsset(id) {
    try {
      await this.api.delete(this.api.sessionPath(`/assets/${encodeURIComponent(id)}`));
      this.onAssetsChanged();
    } catch (e) {
      this.onProblem(e);
    }
    await this.refresh();
  }
}
