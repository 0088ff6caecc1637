// Local lights: generate (count, seed, radius, intensity, falloff C), delete, a paged list, an
// editor for one light (point or spot: direction and cone angles; window or inverse-square), and
// picking a light by clicking its marker in the view. The page knows only a page of the lights,
// so the server picks: GET .../lights/pick with the clicked pixel in the shown frame's pixels
// looks among all of them (a session may hold a million).

import {hexToLinear, linearToHex} from './color.js';
import {fmt, whileBusy} from './panels.js';
import {length, project, sub} from './vec.js';

const $ = (id) => document.getElementById(id);
const PAGE_SIZE = 50;
const PICK_RADIUS_PX = 8;    // how far (CSS pixels) from a marker a click still selects it
const DEGREES = 180 / Math.PI;  // the editor shows cone angles in degrees; the API takes radians
const HALF_PI = Math.PI / 2;
// Fitted ranges (the "Fit ranges" box): radii as fractions of the model's diagonal (the built-in
// scene's 256 lights reach 1 to 3 m of its 34 m diagonal), for up to FIT_COUNT lights; more get
// smaller reach, by the cube root of the ratio, so that a point is reached by about as many
// lights whatever the count (100,000 lights of the reach of 256 washed the scene white).
const FIT_RADIUS = [0.03, 0.09];
const FIT_COUNT = 256;
const SHOWN_DIGITS = 4;  // decimals the editor's fields show (the light keeps all of its own)

export class LightsPanel {
  constructor(api, {onProblem, onInfo, getCamera, getViewSize, getFrameSize, overlay}) {
    this.api = api;
    this.onProblem = onProblem;
    this.onInfo = onInfo;
    this.getCamera = getCamera;      // () => Camera
    this.getViewSize = getViewSize;  // () => {width, height} in CSS pixels
    this.getFrameSize = getFrameSize;  // () => {width, height} of the frame shown, in its pixels
    this.overlay = overlay;          // canvas over the view: the selected light's ring
    this.offset = 0;
    this.total = 0;
    this.page = [];
    this.selected = null;            // a Light
    this.shownVectors = {};          // field id -> the value it shows, rounded, of the light's own
    this.ringDrawn = false;          // the overlay canvas holds a ring
    this.diagonal = 0;               // the model's bounding-box diagonal (fitted ranges)

    $('gen-lights').addEventListener('click', () =>
        whileBusy($('gen-lights'), 'Generating\u2026', () => this.generate()));
    $('delete-lights').addEventListener('click', () =>
        whileBusy($('delete-lights'), 'Deleting\u2026', () => this.deleteAll()));
    $('gen-count').addEventListener('input', () => this.fitRanges());
    $('gen-fit').addEventListener('change', () => this.fitRanges());
    // A range typed in is the user's: fitting stops until the box is ticked again.
    for (const id of ['gen-radius-min', 'gen-radius-max']) {
      $(id).addEventListener('input', () => { $('gen-fit').checked = false; });
    }
    $('lights-prev').addEventListener('click', () => this.showPage(this.offset - PAGE_SIZE));
    $('lights-next').addEventListener('click', () => this.showPage(this.offset + PAGE_SIZE));
    $('light-editor').addEventListener('submit', (e) => {
      e.preventDefault();
      whileBusy($('light-apply'), 'Applying\u2026', () => this.applyEdit());
    });
    $('light-delete').addEventListener('click', () =>
        whileBusy($('light-delete'), 'Deleting\u2026', () => this.deleteSelected()));
    $('light-type').addEventListener('change', () => this.showCone());
  }

  // The model's bounds (a new model, a new session): fitted ranges follow its size.
  setModelBounds(bounds) {
    const d = bounds ? length(sub(bounds.max, bounds.min)) : 0;
    this.diagonal = Number.isFinite(d) && d > 0 ? d : 0;
    this.fitRanges();
  }

  // The radius range for the count and the model (FIT_RADIUS), while "Fit ranges" is ticked.
  fitRanges() {
    const count = $('gen-count').valueAsNumber;
    if (!$('gen-fit').checked || !this.diagonal || !(count > 0)) return;
    const k = Math.min(1, Math.cbrt(FIT_COUNT / count));
    const [min, max] = FIT_RADIUS.map((f) => Number((f * this.diagonal * k).toPrecision(3)));
    $('gen-radius-min').value = String(min);
    $('gen-radius-max').value = String(max);
  }

  numberField(id) {
    const value = $(id).valueAsNumber;
    if (!Number.isFinite(value)) throw new Error(`${$(id).labels[0]?.textContent || id} is not a number.`);
    return value;
  }

  async generate() {
    let body;
    try {
      body = {
        count: Math.round(this.numberField('gen-count')),
        seed: Math.round(this.numberField('gen-seed')),
        replace: $('gen-replace').checked,
        radius: [this.numberField('gen-radius-min'), this.numberField('gen-radius-max')],
        intensity: [this.numberField('gen-intensity-min'), this.numberField('gen-intensity-max')],
        falloff: this.numberField('gen-falloff'),
      };
    } catch (e) {
      this.onProblem(e);
      return;
    }
    this.onInfo(`Generating ${body.count} lights...`);
    try {
      const {total} = await this.api.post(this.api.sessionPath('/lights/generate'), body);
      this.onInfo(null);
      this.changed(total);
    } catch (e) {
      this.onProblem(e);
    }
  }

  async deleteAll() {
    try {
      await this.api.delete(this.api.sessionPath('/lights'));
      this.changed(0);
    } catch (e) {
      this.onProblem(e);
    }
  }

  // After the set of lights changed: back to the first page, nothing selected.
  changed(total) {
    this.total = total;
    this.select(null);
    this.showPage(0);
  }

  async showPage(offset) {
    offset = Math.max(0, offset);
    try {
      const answer = await this.api.get(this.api.sessionPath('/lights'),
                                        {query: {offset, limit: PAGE_SIZE}});
      this.offset = answer.offset;
      this.total = answer.total;
      this.page = answer.lights;
      this.renderList();
    } catch (e) {
      this.onProblem(e);
    }
  }

  // Another page (or a script) changed the session: the open editor shows the light as it is
  // now, or closes when it is gone; not while the user is typing in it (their edit wins).
  async refreshSelected() {
    const id = this.selected?.id;
    if (id === undefined || $('light-editor').contains(document.activeElement)) return;
    let fresh = this.page.find((l) => l.id === id);
    if (!fresh) {
      try {
        fresh = await this.api.get(this.api.sessionPath(`/lights/${id}`));
      } catch (e) {
        if (e.status !== 404) return this.onProblem(e);
        fresh = null;
      }
    }
    if (this.selected?.id !== id) return;  // the user chose another meanwhile
    if (!fresh) this.select(null);
    else if (JSON.stringify(fresh) !== JSON.stringify(this.selected)) this.select(fresh);
  }

  renderList() {
    const last = Math.min(this.total, this.offset + this.page.length);
    $('lights-summary').textContent = `${this.total} lights`;
    $('lights-page').textContent = this.total ? `${this.offset + 1}\u2013${last} of ${this.total}` : 'none';
    $('lights-prev').disabled = this.offset === 0;
    $('lights-next').disabled = last >= this.total;
    $('light-list').replaceChildren(...this.page.map((light) => {
      const item = document.createElement('li');
      item.dataset.id = light.id;
      const swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = linearToHex(light.color);
      // A button: the list is used from the keyboard too (Tab, Enter).
      const text = document.createElement('button');
      text.type = 'button';
      text.className = 'name';
      text.textContent = `#${light.id} ${light.type === 'spot' ? 'spot ' : ''}${fmt(light.position)} r=${+light.radius.toFixed(3)}`;
      text.setAttribute('aria-pressed', String(light.id === this.selected?.id));
      item.append(swatch, text);
      item.classList.toggle('selected', light.id === this.selected?.id);
      item.addEventListener('click', () => {
        this.select(light);
        this.revealEditor();
      });
      return item;
    }));
  }

  select(light) {
    this.selected = light;
    for (const item of $('light-list').children) {
      const on = Number(item.dataset.id) === light?.id;
      item.classList.toggle('selected', on);
      item.querySelector('button.name')?.setAttribute('aria-pressed', String(on));
    }
    $('light-editor').hidden = !light;
    if (light) {
      $('light-editor-title').textContent = `Light #${light.id}`;
      this.showVector(['light-x', 'light-y', 'light-z'], light.position);
      $('light-color').value = linearToHex(light.color);
      $('light-radius').value = light.radius;
      $('light-intensity').value = light.intensity;
      $('light-falloff').value = light.falloff;
      $('light-attenuation').value = light.attenuation;
      $('light-type').value = light.type;
      this.showVector(['light-dx', 'light-dy', 'light-dz'], light.direction);
      $('light-inner').value = +(light.innerConeAngle * DEGREES).toFixed(4);
      $('light-outer').value = +(light.outerConeAngle * DEGREES).toFixed(4);
      $('light-shadows').checked = light.castsShadows === true;
      this.showCone();
      this.shownFields = {};
      for (const id of Object.values(LightsPanel.FIELDS).flat()) this.shownFields[id] = this.fieldValue(id);
    }
    this.drawOverlay();
  }

  // A vector in three fields, rounded to SHOWN_DIGITS so that it fits; the full value is each
  // field's tooltip, and a field left as shown sends the light's own value back (vectorField).
  showVector(ids, values) {
    ids.forEach((id, i) => {
      const shown = String(+values[i].toFixed(SHOWN_DIGITS));
      $(id).value = shown;
      $(id).title = String(values[i]);
      this.shownVectors[id] = {shown, value: values[i]};
    });
  }

  vectorField(ids) {
    return ids.map((id) => {
      const known = this.shownVectors[id];
      return known && $(id).value === known.shown ? known.value : this.numberField(id);
    });
  }

  // The editor where it can be seen (its section open, scrolled into the panel's view).
  revealEditor() {
    const section = $('light-editor').closest('details');
    if (section) section.open = true;
    $('light-editor').scrollIntoView({block: 'nearest'});
  }

  // What each member of a light is edited in: a member is sent only when one of its fields no
  // longer shows what select() put there.
  static FIELDS = {
    position: ['light-x', 'light-y', 'light-z'], color: ['light-color'],
    radius: ['light-radius'], intensity: ['light-intensity'], falloff: ['light-falloff'],
    attenuation: ['light-attenuation'], type: ['light-type'], castsShadows: ['light-shadows'],
    direction: ['light-dx', 'light-dy', 'light-dz'], innerConeAngle: ['light-inner'],
    outerConeAngle: ['light-outer'],
  };

  fieldValue(id) {
    const field = $(id);
    return field.type === 'checkbox' ? String(field.checked) : field.value;
  }

  // Apply sends the members the user changed, and only over the light as the editor showed it:
  // the light is read again with the session's ETag, a member changed elsewhere meanwhile (by
  // another page or a script) stops the edit (the editor then shows the light as it is, and says
  // so), and the PATCH is conditional on that ETag (If-Match), so nothing lands between the read
  // and the write unseen. A 412 from an unrelated edit (the camera moved) reads again.
  async applyEdit() {
    const light = this.selected;
    if (!light) return;
    let patch;
    try {
      patch = {
        position: this.vectorField(['light-x', 'light-y', 'light-z']),
        color: hexToLinear($('light-color').value),
        radius: this.numberField('light-radius'),
        intensity: this.numberField('light-intensity'),
        falloff: this.numberField('light-falloff'),
        attenuation: $('light-attenuation').value,
        type: $('light-type').value,
        castsShadows: $('light-shadows').checked,
      };
      if (patch.type === 'spot') {
        patch.direction = this.vectorField(['light-dx', 'light-dy', 'light-dz']);
        // Radians on the wire; the server refuses inner >= outer, naming the member.
        patch.innerConeAngle = Math.min(this.numberField('light-inner') / DEGREES, HALF_PI);
        patch.outerConeAngle = Math.min(this.numberField('light-outer') / DEGREES, HALF_PI);
      }
    } catch (e) {
      this.onProblem(e);
      return;
    }
    for (const member of Object.keys(patch)) {
      const fields = LightsPanel.FIELDS[member];
      if (fields.every((id) => this.fieldValue(id) === this.shownFields[id])) delete patch[member];
    }
    if (Object.keys(patch).length === 0) return;
    const path = this.api.sessionPath(`/lights/${light.id}`);
    const changedElsewhere = (current) => Object.keys(patch).filter(
        (member) => JSON.stringify(current[member]) !== JSON.stringify(light[member]));
    try {
      const {conflict, updated} = await this.api.patchIfUnchanged(
          path, patch, (current) => changedElsewhere(current).length === 0);
      if (conflict) {
        this.replace(conflict);
        this.select(conflict);
        this.onProblem(new Error(
            `Light #${light.id} was changed elsewhere while you edited it ` +
            `(${changedElsewhere(conflict).join(', ')}): your change was not applied; the editor ` +
            'shows the light as it is now.'));
        return;
      }
      this.replace(updated);
      this.select(updated);
    } catch (e) {
      this.onProblem(e);
    }
  }

  // Direction and cone angles only mean something for a spot light.
  showCone() {
    const spot = $('light-type').value === 'spot';
    for (const id of ['light-dx', 'light-inner', 'light-outer']) {
      const field = $(id);
      (field.closest('.row') ?? field).hidden = !spot;
      const label = document.querySelector(`label[for="${id}"]`);
      if (label) label.hidden = !spot;
    }
  }

  replace(light) {
    const i = this.page.findIndex((l) => l.id === light.id);
    if (i >= 0) this.page[i] = light;
    this.renderList();
  }

  async deleteSelected() {
    const light = this.selected;
    if (!light) return;
    try {
      await this.api.delete(this.api.sessionPath(`/lights/${light.id}`));
      this.changed(this.total - 1);
    } catch (e) {
      this.onProblem(e);
    }
  }

  // A click in the view at (x, y) CSS pixels: the server names the light whose marker is under
  // that pixel of the frame shown (or within PICK_RADIUS_PX of it), whichever of the session's
  // lights it is; the editor opens where it can be seen.
  async pick(x, y) {
    const view = this.getViewSize();
    const frame = this.getFrameSize();
    if (!view.width || !view.height || !frame.width || !frame.height) return;
    const sx = frame.width / view.width;
    const sy = frame.height / view.height;
    const query = {
      x: Math.min(frame.width - 0.01, Math.max(0, x * sx)).toFixed(2),
      y: Math.min(frame.height - 0.01, Math.max(0, y * sy)).toFixed(2),
      width: frame.width, height: frame.height,
      radius: Math.min(64, PICK_RADIUS_PX * sx).toFixed(2),
    };
    let answer;
    try {
      answer = await this.api.get(this.api.sessionPath('/lights/pick'), {query});
    } catch (e) {
      this.onProblem(e);
      return;
    }
    if (!answer.light) return;
    this.select(answer.light);
    this.revealEditor();
  }

  // A ring around the selected light, re-projected whenever the camera or the view changes.
  drawOverlay() {
    // Called on every camera move: with no light selected and no ring drawn there is nothing to
    // do, not even reading the view's size (a forced style and layout pass when the page changed
    // since the last frame). The canvas takes the view's size when a ring is drawn next.
    if (!this.selected && !this.ringDrawn) return;
    const canvas = this.overlay;
    const {width, height} = this.getViewSize();
    const ratio = window.devicePixelRatio || 1;
    // Resizing a canvas clears it.
    if (canvas.width !== Math.round(width * ratio)) {
      canvas.width = Math.round(width * ratio);
      this.ringDrawn = false;
    }
    if (canvas.height !== Math.round(height * ratio)) {
      canvas.height = Math.round(height * ratio);
      this.ringDrawn = false;
    }
    const camera = this.getCamera();
    const p = this.selected && camera ? project(camera, this.selected.position, width, height) : null;
    // Called on every camera move: a view-sized canvas cleared each time is a view-sized layer
    // for the compositor to take again (in software, on the cores the server renders on), so it
    // is touched only when a ring is or was on it.
    if (!p && !this.ringDrawn) return;
    const g = canvas.getContext('2d');
    g.clearRect(0, 0, canvas.width, canvas.height);
    this.ringDrawn = false;
    if (!p) return;
    this.ringDrawn = true;
    g.scale(ratio, ratio);
    g.strokeStyle = '#5fa8ff';
    g.lineWidth = 2;
    g.beginPath();
    g.arc(p.x, p.y, 10, 0, 2 * Math.PI);
    g.stroke();
    g.setTransform(1, 0, 0, 1, 0, 0);
  }
}
