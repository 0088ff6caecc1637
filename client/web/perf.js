// What the live view feels like, measured in the page: frames shown a second while the user
// drags (the camera or a slider), the time from a change to the first frame that shows it, and
// from a release (pointer up, a slider let go) to the full-quality still. A frame counts when
// the page shows it (the <img>'s load, a video picture drawn), not when its bytes arrive.
//
// The browser test and scripts/bench-page.sh read it as window.myriadPerf (main.js); the page
// itself shows none of it. Figures are kept for the last MAX_SAMPLES events of each kind.

const MAX_SAMPLES = 1000;

function push(list, value) {
  list.push(value);
  if (list.length > MAX_SAMPLES) list.shift();
}

export class ViewPerf {
  constructor() {
    this.onDrag = () => {};  // (drag figures) at each release: the view learns its scale from them
    this.reset();
  }

  // Forgets every figure (a benchmark starts a measurement with it).
  reset() {
    this.frames = [];    // {t, id, interactive (render scale or 0), width, height}: shown frames
    // {ms, frames, interactiveFrames, fps, inputs, spanMs}: one per drag, at its release; inputs
    // are the changes it made, spanMs the time from its first picture to its last
    this.drags = [];
    this.changes = [];   // ms from a change to the first new frame shown after it
    this.stills = [];    // ms from a release to the first full-quality frame shown after it
    this.drag = null;    // the drag going on: {start, frames, interactiveFrames, inputs, first, last}
    this.changeAt = 0;   // performance.now() of the oldest change no frame shows yet
    this.changeFrame = '';
    this.releaseAt = 0;  // performance.now() of the last release whose still has not shown
    this.lastFrame = '';
  }

  // A pointer went down on the view or a slider: a drag starts.
  dragStart() {
    this.drag = {start: performance.now(), frames: 0, interactiveFrames: 0, inputs: 0, first: 0, last: 0};
    this.releaseAt = 0;
  }

  // Something that changes the picture happened (camera input, a slider moved).
  change() {
    if (this.drag) this.drag.inputs += 1;
    if (!this.changeAt) {
      this.changeAt = performance.now();
      this.changeFrame = this.lastFrame;
    }
  }

  // The pointer went up (or a slider was let go): the drag's figures are kept, and the time to
  // the full-quality still starts.
  release() {
    const now = performance.now();
    if (this.drag) {
      const ms = now - this.drag.start;
      const d = this.drag;
      const drag = {ms, frames: d.frames, interactiveFrames: d.interactiveFrames,
                    fps: ms > 0 ? (1000 * d.frames) / ms : 0, inputs: d.inputs,
                    spanMs: d.frames > 1 ? d.last - d.first : 0};
      push(this.drags, drag);
      this.drag = null;
      this.onDrag(drag);
    }
    this.releaseAt = now;
  }

  // A frame is on screen. `id` names it (a re-send keeps its id and is not counted);
  // `interactive` is its render scale when the server rendered it cheaper (0: full quality).
  shown({id, interactive = 0, width = 0, height = 0}) {
    if (id === this.lastFrame) return;
    const t = performance.now();
    this.lastFrame = id;
    push(this.frames, {t, id, interactive, width, height});
    if (this.drag) {
      if (!this.drag.frames) this.drag.first = t;
      this.drag.last = t;
      this.drag.frames += 1;
      if (interactive) this.drag.interactiveFrames += 1;
    }
    if (this.changeAt && id !== this.changeFrame) {
      push(this.changes, t - this.changeAt);
      this.changeAt = 0;
    }
    if (this.releaseAt && !interactive && !this.drag) {
      push(this.stills, t - this.releaseAt);
      this.releaseAt = 0;
    }
  }

  // Frames shown a second over the last `ms` milliseconds.
  fps(ms = 2000) {
    const since = performance.now() - ms;
    return (1000 * this.frames.filter((f) => f.t >= since).length) / ms;
  }

  // Everything above as plain data (what page.evaluate returns).
  toJSON() {
    return {frames: this.frames, drags: this.drags, changes: this.changes, stills: this.stills,
            dragging: this.drag !== null};
  }
}
