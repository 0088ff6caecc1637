// Camera input. Orbit: left drag turns the eye around the target, the wheel zooms, right or
// middle drag pans; on a touch screen one finger orbits, two pinch to zoom and drag to pan; from
// the keyboard (the view focused) the arrow keys orbit (with Shift they pan) and + / - zoom. Fly:
// hold the right button to look around (or the arrow keys), WASD to move, Q/E down/up, Shift
// faster. The camera itself lives on the server: every change is sent as PATCH camera (at most
// ~30 a second, one request in flight, always the newest pose) and the stream shows the result.

import {PatchSender} from './sender.js';
import {add, cameraBasis, cross, dot, length, normalize, rotate, scale, sub} from './vec.js';

const ORBIT_RADIANS_PER_PIXEL = 0.006;
const LOOK_RADIANS_PER_PIXEL = 0.003;
const ZOOM_PER_WHEEL_UNIT = 0.0015;  // exp(deltaY * this): one notch (100) is ~16 %
const MIN_POLAR = 0.01;              // radians kept between the view direction and up
const SEND_INTERVAL_MS = 33;         // ~30 PATCHes a second at most
const CLICK_SLOP_PX = 4;             // a press that moved less than this is a click
const FAST_FACTOR = 4;               // Shift in fly mode
const FLY_KEYS = new Set(['KeyW', 'KeyA', 'KeyS', 'KeyD', 'KeyQ', 'KeyE']);
// The view's keys: an arrow press (or each auto-repeat, ~30 a second) moves as a drag of this many
// pixels would; + / - zoom as a wheel notch does.
const KEY_STEP_PX = 12;
const KEY_ZOOM = Math.exp(100 * ZOOM_PER_WHEEL_UNIT);
const ARROWS = {ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1]};

export class CameraControl {
  constructor(api, element, view) {
    this.api = api;
    this.element = element;
    this.view = view;
    this.camera = null;          // the last pose, as the server holds it (or is about to)
    this.mode = 'orbit';
    this.flySpeed = 1;           // scene units a second, from the model's size
    this.drag = null;            // {button, x, y, startX, startY, moved}
    this.keys = new Set();
    this.fast = false;
    this.flyFrame = 0;
    // PATCH camera: one in flight, the newest pose, end() when a drag is released.
    this.sender = new PatchSender(
        (pose, end) => this.api.patch(this.api.sessionPath('/camera'), pose, end), SEND_INTERVAL_MS);
    this.sender.onAnswer = (answer) => { this.camera = answer; };
    this.sender.onProblem = (e) => this.onProblem(e);
    this.touches = new Map();    // pointerId -> {x, y} of the fingers on the view
    this.pinch = null;           // {distance, x, y} of two fingers, while they pinch or pan
    this.onClick = () => {};     // (x, y) in CSS pixels of the view, for light picking
    this.onChange = () => {};    // the pose changed (local or from the server)
    this.onProblem = () => {};   // (ApiError)

    element.addEventListener('contextmenu', (e) => e.preventDefault());
    element.addEventListener('pointerdown', (e) => this.pointerDown(e));
    element.addEventListener('pointermove', (e) => this.pointerMove(e));
    element.addEventListener('pointerup', (e) => this.pointerUp(e));
    element.addEventListener('pointercancel', (e) => this.pointerUp(e));
    element.addEventListener('wheel', (e) => this.wheel(e), {passive: false});
    element.addEventListener('keydown', (e) => this.viewKey(e));
    element.addEventListener('keyup', (e) => {
      // The last key of a keyboard move released: its still at once, as a drag's release.
      if (e.key in ARROWS || ['+', '=', '-', '_'].includes(e.key)) this.sender.end();
    });
    window.addEventListener('keydown', (e) => this.keyDown(e));
    window.addEventListener('keyup', (e) => this.keyUp(e));
    window.addEventListener('blur', () => this.keys.clear());
  }

  // A pose from the server (session state, a PATCH answer, camera/frame). Ignored while the user
  // is moving the camera, so a late answer cannot pull the view back.
  setFromServer(camera) {
    if (this.drag || this.keys.size || this.sender.busy) return;
    this.camera = camera;
    this.onChange(camera);
  }

  setModelBounds(bounds) {
    const size = bounds ? length(sub(bounds.max, bounds.min)) : 0;
    this.flySpeed = Number.isFinite(size) && size > 0 ? size * 0.25 : 1;
  }

  setMode(mode) {
    this.mode = mode;
    this.keys.clear();
  }

  pointerDown(e) {
    // The message box and the stats strip sit on the view: their clicks are theirs.
    if (e.target.closest?.('[data-no-camera]')) return;
    if (e.pointerType === 'touch' && this.touchDown(e)) return;
    if (!this.camera || this.drag) return;
    this.element.focus();
    this.element.setPointerCapture(e.pointerId);
    this.drag = {button: e.button, x: e.clientX, y: e.clientY, startX: e.clientX,
                 startY: e.clientY, moved: false};
    this.element.classList.add('dragging');
    e.preventDefault();
  }

  // Touch: one finger drags as the left button does; a second finger turns the gesture into a
  // pinch (the change in the fingers' distance zooms) and a two-finger pan (their midpoint moves
  // the camera as a right drag does). True when the event belongs to a two-finger gesture.
  touchDown(e) {
    this.touches.set(e.pointerId, {x: e.clientX, y: e.clientY});
    if (this.touches.size < 2) return false;
    this.element.setPointerCapture(e.pointerId);
    this.drag = null;  // the first finger's drag becomes the pinch
    this.element.classList.remove('dragging');
    this.pinch = this.twoFingers();
    e.preventDefault();
    return true;
  }

  twoFingers() {
    const [a, b] = [...this.touches.values()];
    return {distance: Math.max(1, Math.hypot(a.x - b.x, a.y - b.y)),
            x: (a.x + b.x) / 2, y: (a.y + b.y) / 2};
  }

  touchMove(e) {
    this.touches.set(e.pointerId, {x: e.clientX, y: e.clientY});
    if (!this.pinch || this.touches.size < 2 || !this.camera) return;
    const now = this.twoFingers();
    const before = this.pinch;
    this.pinch = now;
    // Fingers apart: closer to the target, by the ratio of their distances.
    this.zoomBy(before.distance / now.distance);
    if (this.mode === 'orbit') this.pan(now.x - before.x, now.y - before.y);
  }

  touchUp(e) {
    this.touches.delete(e.pointerId);
    if (this.touches.size < 2) this.pinch = null;
  }

  pointerMove(e) {
    if (e.pointerType === 'touch' && this.touches.has(e.pointerId)) {
      this.touchMove(e);
      if (this.pinch) return;
    }
    const drag = this.drag;
    if (!drag) return;
    const dx = e.clientX - drag.x;
    const dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (!drag.moved &&
        Math.hypot(e.clientX - drag.startX, e.clientY - drag.startY) < CLICK_SLOP_PX) {
      return;
    }
    drag.moved = true;
    if (this.mode === 'orbit') {
      if (drag.button === 0) this.orbit(dx, dy);
      else this.pan(dx, dy);
    } else if (drag.button === 2) {
      this.look(dx, dy);
    }
  }

  pointerUp(e) {
    if (e.pointerType === 'touch') {
      const pinching = this.pinch !== null;
      this.touchUp(e);
      if (pinching) return;
    }
    const drag = this.drag;
    if (!drag) return;
    this.drag = null;
    this.element.classList.remove('dragging');
    if (drag.moved) {
      // The pose once more, at once, saying the drag ended: the stream's still needs no settle
      // time then (X-Myriad-Interaction: end).
      this.sender.end();
    }
    if (!drag.moved && drag.button === 0) {
      const rect = this.element.getBoundingClientRect();
      this.onClick(e.clientX - rect.left, e.clientY - rect.top);
    }
  }

  wheel(e) {
    if (!this.camera) return;
    e.preventDefault();
    this.zoomBy(Math.exp(e.deltaY * ZOOM_PER_WHEEL_UNIT));
  }

  // Moves the eye towards (factor < 1) or away from the target.
  zoomBy(factor) {
    if (!Number.isFinite(factor) || factor <= 0) return;
    const offset = sub(this.camera.eye, this.camera.target);
    const distance = length(offset);
    const minDistance = Math.max(this.camera.near * 2, 1e-3);
    const next = Math.max(minDistance, distance * factor);
    this.update({eye: add(this.camera.target, scale(offset, next / distance))});
  }

  // Turns the eye around the target: yaw about the camera's up, pitch about its right axis,
  // never reaching the up direction (the server refuses up parallel to the view).
  orbit(dx, dy) {
    const c = this.camera;
    const up = normalize(c.up);
    let offset = rotate(sub(c.eye, c.target), up, -dx * ORBIT_RADIANS_PER_PIXEL);
    const right = normalize(cross(up, offset));
    const pitched = rotate(offset, right, -dy * ORBIT_RADIANS_PER_PIXEL);
    const polar = Math.acos(Math.min(1, Math.max(-1, dot(normalize(pitched), up))));
    if (polar > MIN_POLAR && polar < Math.PI - MIN_POLAR) offset = pitched;
    this.update({eye: add(c.target, offset)});
  }

  // Moves eye and target together in the view plane; a pixel moves by what it covers at the
  // target's distance, so the point under the cursor stays under it.
  pan(dx, dy) {
    const c = this.camera;
    const {right, up} = cameraBasis(c);
    const distance = length(sub(c.target, c.eye));
    const perPixel = (2 * distance * Math.tan((c.fovY * Math.PI) / 360)) /
                     Math.max(1, this.element.clientHeight);
    const move = add(scale(right, -dx * perPixel), scale(up, dy * perPixel));
    this.update({eye: add(c.eye, move), target: add(c.target, move)});
  }

  // Fly look: the view direction turns around the eye; the target stays at the same distance.
  look(dx, dy) {
    const c = this.camera;
    const up = normalize(c.up);
    const distance = length(sub(c.target, c.eye));
    let forward = rotate(normalize(sub(c.target, c.eye)), up, -dx * LOOK_RADIANS_PER_PIXEL);
    const right = normalize(cross(forward, up));
    const pitched = rotate(forward, right, -dy * LOOK_RADIANS_PER_PIXEL);
    const polar = Math.acos(Math.min(1, Math.max(-1, dot(pitched, up))));
    if (polar > MIN_POLAR && polar < Math.PI - MIN_POLAR) forward = pitched;
    this.update({target: add(c.eye, scale(forward, distance))});
  }

  // Keys on the focused view: arrows orbit (Shift: pan; fly: look), + / - zoom. A key held
  // repeats, and each repeat is one more change, sent as a drag's are.
  viewKey(e) {
    if (!this.camera || e.ctrlKey || e.metaKey || e.altKey || e.target !== this.element) return;
    const arrow = ARROWS[e.key];
    if (arrow) {
      const [dx, dy] = arrow.map((a) => a * KEY_STEP_PX);
      if (this.mode === 'fly') this.look(dx, dy);
      else if (e.shiftKey) this.pan(-dx, -dy);
      else this.orbit(dx, dy);
    } else if (e.key === '+' || e.key === '=') {
      this.zoomBy(1 / KEY_ZOOM);
    } else if (e.key === '-' || e.key === '_') {
      this.zoomBy(KEY_ZOOM);
    } else {
      return;
    }
    e.preventDefault();
  }

  keyDown(e) {
    if (isTyping(e)) return;
    this.fast = e.shiftKey;
    if (this.mode !== 'fly' || !FLY_KEYS.has(e.code) || e.ctrlKey || e.metaKey || e.altKey) return;
    e.preventDefault();
    this.keys.add(e.code);
    if (!this.flyFrame) {
      let last = performance.now();
      const step = (now) => {
        const dt = Math.min(0.1, (now - last) / 1000);
        last = now;
        this.flyStep(dt);
        this.flyFrame = this.keys.size ? requestAnimationFrame(step) : 0;
      };
      this.flyFrame = requestAnimationFrame(step);
    }
  }

  keyUp(e) {
    this.fast = e.shiftKey;
    this.keys.delete(e.code);
  }

  flyStep(dt) {
    const c = this.camera;
    if (!c || !this.keys.size) return;
    const {forward, right} = cameraBasis(c);
    const up = normalize(c.up);
    const axis = (plus, minus) => (this.keys.has(plus) ? 1 : 0) - (this.keys.has(minus) ? 1 : 0);
    let move = add(add(scale(forward, axis('KeyW', 'KeyS')), scale(right, axis('KeyD', 'KeyA'))),
                   scale(up, axis('KeyE', 'KeyQ')));
    if (length(move) === 0) return;
    move = scale(normalize(move), this.flySpeed * dt * (this.fast ? FAST_FACTOR : 1));
    this.update({eye: add(c.eye, move), target: add(c.target, move)});
  }

  // A pose from the server replaces the one not sent yet (a model loaded, camera/frame).
  dropPending() {
    this.sender.drop();
  }

  // A local change: shown at once in the next streamed frame after the PATCH lands.
  update(change) {
    this.camera = {...this.camera, ...change};
    this.view.noteInput();
    this.onChange(this.camera);
    const {eye, target, up} = this.camera;
    this.sender.queue({eye, target, up});
  }

  // POST camera/frame (the F key): the server frames the model's bounds.
  async frameModel() {
    try {
      this.sender.drop();
      const camera = await this.api.post(this.api.sessionPath('/camera/frame'), {});
      this.camera = camera;
      this.view.noteInput();
      this.onChange(camera);
    } catch (e) {
      this.onProblem(e);
    }
  }

  // The camera as PUT camera takes it, and as a curl command that restores it.
  asJson() {
    const {eye, target, up, fovY, near, far} = this.camera;
    return JSON.stringify({eye, target, up, fovY, near, far});
  }

  asCurl() {
    const url = `${location.origin}${this.api.sessionPath('/camera')}`;
    return `curl -X PUT -H 'Authorization: Bearer ${this.api.session.token}' ` +
           `-H 'Content-Type: application/json' -d '${this.asJson()}' '${url}'`;
  }
}

// Keys typed into a form field are not camera or shortcut keys.
export function isTyping(e) {
  const t = e.target;
  return t instanceof HTMLElement &&
         (t.isContentEditable || ['INPUT', 'SELECT', 'TEXTAREA'].includes(t.tagName)) &&
         !(t instanceof HTMLInputElement && ['checkbox', 'range', 'color', 'button'].includes(t.type));
}
