// The handles of the selected object, drawn over the view at the centre of its world bounds. The
// move handle: drag it (or focus it and press the arrow keys) and the object moves in the view
// plane at its own depth, so it stays under the pointer. The turn handle: a drag (or the arrows)
// turns it about the camera's up axis (left and right) and right axis (up and down). Each change
// is a PATCH of the object's whole transform, as the outliner's fields send it: one request in
// flight, at most ~30 a second, the newest transform. An object under a parent moves and turns in
// its parent's axes, taken here as the world's: under a turned or scaled parent the handle does
// not follow the pointer exactly.

import {PatchSender} from './sender.js';
import {add, axisAngleQuat, cameraBasis, dot, project, quatMultiply, scale, sub,
        transformParts} from './vec.js';

const SEND_INTERVAL_MS = 33;
const TURN_RADIANS_PER_PIXEL = 0.01;
// An arrow press moves as a drag of KEY_STEP_PX would, or turns by KEY_TURN_DEGREES.
const KEY_STEP_PX = 16;
const KEY_TURN_DEGREES = 15;
const KEY_TURN_PX = (KEY_TURN_DEGREES * Math.PI) / 180 / TURN_RADIANS_PER_PIXEL;
const ARROWS = {ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1]};

const centreOf = (bounds) => bounds.min.map((v, i) => (v + bounds.max[i]) / 2);

export class ObjectHandle {
  // element: the handles' box; its buttons [data-handle=move|turn].
  constructor(api, element, {getCamera, getViewSize, onAnswer, onProblem}) {
    this.api = api;
    this.element = element;
    this.getCamera = getCamera;      // () => the camera pose shown
    this.getViewSize = getViewSize;  // () => {width, height} in CSS pixels
    this.object = null;              // the selected object, as the server gave it
    this.edit = null;                // {id, translation, rotation, scale, centre} being changed
    this.drag = null;                // {mode, x, y} while a handle is held
    this.keyHeld = false;            // an arrow on a handle is down (ends when released)
    this.sender = new PatchSender((patch, end) =>
        this.api.patch(this.api.sessionPath(`/objects/${this.edit.id}`), patch, end), SEND_INTERVAL_MS);
    this.sender.onAnswer = (object) => onAnswer(object);
    this.sender.onProblem = (e) => {
      this.edit = null;
      onProblem(e);
      this.place();
    };
    for (const button of element.querySelectorAll('[data-handle]')) {
      const mode = button.dataset.handle;
      button.addEventListener('pointerdown', (e) => this.pointerDown(e, mode));
      button.addEventListener('pointermove', (e) => this.pointerMove(e));
      button.addEventListener('pointerup', (e) => this.pointerUp(e));
      button.addEventListener('pointercancel', (e) => this.pointerUp(e));
      button.addEventListener('keydown', (e) => this.key(e, mode));
      button.addEventListener('keyup', (e) => {
        if (!(e.key in ARROWS)) return;
        e.stopPropagation();
        this.keyReleased();
      });
      button.addEventListener('blur', () => this.keyReleased());  // its keyup goes elsewhere
    }
  }

  get busy() {
    return this.drag !== null || this.keyHeld || this.sender.busy;
  }

  // The selected object (or null) as the outliner shows it. While the user moves it the handle
  // keeps its own transform, so a late answer cannot pull it back.
  show(object) {
    if (this.busy && object && this.edit && object.id === this.edit.id) return;
    this.object = object;
    this.edit = null;
    const who = object ? `object #${object.id}` : 'the object';
    for (const button of this.element.querySelectorAll('[data-handle]')) {
      const what = button.dataset.handle === 'move' ? `Move ${who}` : `Turn ${who}`;
      button.setAttribute('aria-label', `${what}: drag, or the arrow keys`);
    }
    this.place();
  }

  // Where the object's centre is in the view now (camera moves call it too); hidden without one.
  place() {
    const camera = this.getCamera();
    const centre = this.edit?.centre || (this.object?.bounds && centreOf(this.object.bounds));
    const {width, height} = this.getViewSize();
    const p = centre && camera && width && height ? project(camera, centre, width, height) : null;
    const inside = p && p.x >= 0 && p.y >= 0 && p.x <= width && p.y <= height;
    this.element.hidden = !inside;
    if (inside) this.element.style.transform = `translate(${p.x.toFixed(1)}px, ${p.y.toFixed(1)}px)`;
  }

  // The transform the handle changes: the object's, or the one it is already changing.
  begin() {
    const o = this.object;
    if (!o || !o.bounds) return false;
    if (this.edit?.id === o.id) return true;
    if (this.sender.busy) return false;  // the last object's transform is still on its way
    const {translation, rotation, scale: s} = transformParts(o.transform);
    this.edit = {id: o.id, translation, rotation, scale: s, centre: centreOf(o.bounds)};
    return true;
  }

  // A move of (dx, dy) CSS pixels: the world distance that many pixels span at the object's depth.
  apply(mode, dx, dy) {
    const camera = this.getCamera();
    if (!camera || !this.begin()) return;
    const {forward, right, up} = cameraBasis(camera);
    const edit = this.edit;
    if (mode === 'move') {
      const depth = Math.max(camera.near || 1e-3, dot(sub(edit.centre, camera.eye), forward));
      const perPixel = (2 * depth * Math.tan((camera.fovY * Math.PI) / 360)) / this.getViewSize().height;
      const delta = add(scale(right, dx * perPixel), scale(up, -dy * perPixel));
      edit.translation = add(edit.translation, delta);
      edit.centre = add(edit.centre, delta);
    } else {
      // Right turns the near side right (about up); down turns it down (about right).
      const turn = quatMultiply(axisAngleQuat(up, dx * TURN_RADIANS_PER_PIXEL),
                                axisAngleQuat(right, dy * TURN_RADIANS_PER_PIXEL));
      edit.rotation = quatMultiply(turn, edit.rotation);
    }
    this.place();
    this.sender.queue({transform: {translation: edit.translation, rotation: edit.rotation,
                                   scale: edit.scale}});
  }

  pointerDown(e, mode) {
    if (e.button !== 0 || !this.begin()) return;
    e.preventDefault();
    e.stopPropagation();
    e.currentTarget.setPointerCapture(e.pointerId);
    e.currentTarget.focus();
    this.drag = {mode, x: e.clientX, y: e.clientY};
  }

  pointerMove(e) {
    const drag = this.drag;
    if (!drag) return;
    e.stopPropagation();
    const dx = e.clientX - drag.x;
    const dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (dx || dy) this.apply(drag.mode, dx, dy);
  }

  pointerUp(e) {
    if (!this.drag) return;
    e.stopPropagation();
    this.drag = null;
    this.sender.end();
  }

  keyReleased() {
    if (!this.keyHeld) return;
    this.keyHeld = false;
    this.sender.end();
  }

  key(e, mode) {
    const arrow = ARROWS[e.key];
    if (!arrow || e.ctrlKey || e.metaKey || e.altKey) return;
    // The view's own keys (orbit) and the page's shortcuts do not see it.
    e.preventDefault();
    e.stopPropagation();
    const step = mode === 'move' ? KEY_STEP_PX : KEY_TURN_PX;
    this.keyHeld = true;
    this.apply(mode, arrow[0] * step, arrow[1] * step);
  }
}
