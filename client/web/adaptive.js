// The page's side of the interactive contract, the same for every stream: while the user steers
// (a drag, a slider, keys), frames come at a smaller scale so that the page holds its rate, at
// the largest scale that allows it; a full-quality still follows. Learnt from the page's own
// measured frames (perf.js's drag figures: pictures shown, their interval, the input rate), so
// a busy machine gets smaller frames and an idle one larger ones. Pure (no DOM), tested in Node.
//
// JPEG (image) streams: the server picks the scale for `?interactive=N` from its own frame times,
// giving a frame half of 1 / N (the other half is left to the client: input, requests, decode).
// Where the page measures that it holds its rate with room to spare, it needs less than that
// half, so it asks for a lower N: the renderer gets more of the period and the frames grow.
// Measured on lavapipe, 2 cores, 1280x720 (docs/performance.md): N = 24 dragged at 29.5 fps at
// scales around 3/16; N = 12 at 27 fps around 3/8; N = 8 at 18 fps around 9/16.
//
// Video streams keep their size, so the page opens the interaction's stream at a scale of its
// own (InteractiveScale) and the full-size one for the still. Where video misses the rate even at
// its smallest interaction scale (a CPU renderer encodes VP9 and the browser decodes it in
// software: docs/performance.md), the page takes the JPEG stream instead and says why
// (LearntInteraction): the path with the better measured rate.

// The rate the page holds while the user steers (frames shown a second), and while the lights
// animate (half: watched, not steered; the server's own rule for ?interactive=).
export const TARGET_FPS = 24;
export const ANIMATED_FPS = TARGET_FPS / 2;
// A drag counts only when the user asked for at least the target rate: its input (pointer moves,
// keys) came at least this fast. A slow drag says nothing about what the stream can hold.
const MIN_INPUT_FPS = TARGET_FPS;
// A drag holds the rate when its pictures came at least this share of the target.
const HOLDS = 1.0;
// Below this share of the target it misses, and the frames get smaller.
const MISSES = 0.85;
// A step that missed is not tried again for this many drags (the machine may get less busy).
const RETRY_AFTER = 8;

// A drag's figures as ViewPerf records them: frames shown, the time between the first and the
// last (ms), inputs and the drag's length (ms). Its picture rate after the first picture (which
// waits for the stream to react: a new video stream's key frame), or NaN when too short to tell.
export function dragRate({frames, spanMs}) {
  return frames >= 4 && spanMs > 0 ? ((frames - 1) * 1000) / spanMs : NaN;
}

function inputRate({inputs, ms}) {
  return ms > 0 ? (inputs * 1000) / ms : 0;
}

// A choice among `steps` (ascending: larger is better looking, harder to hold), learnt from
// drags: one step up after a drag that held the rate, down after one that missed; a step that
// missed is skipped for RETRY_AFTER drags.
class StepLearner {
  // `descend(value, rate)`: where a drag that missed at `rate` sends the value (at least one step
  // down); without it, one step.
  constructor(steps, start, descend = null) {
    this.steps = steps;
    this.index = Math.max(0, steps.indexOf(start));
    this.missedAt = new Map();  // step index -> drag number when it missed
    this.drags = 0;
    this.descend = descend;
    this.lastRate = NaN;        // the last drag that counted: its picture rate
    this.lastMissed = false;    // ... whether it missed the target
    this.lastIndex = -1;        // ... and the step it ran at
  }

  get value() {
    return this.steps[this.index];
  }

  // One drag at the current step: true when the step changed.
  learn(drag) {
    const rate = dragRate(drag);
    if (!Number.isFinite(rate) || inputRate(drag) < MIN_INPUT_FPS) return false;
    this.drags += 1;
    this.lastRate = rate;
    this.lastIndex = this.index;
    this.lastMissed = rate < MISSES * TARGET_FPS;
    const before = this.index;
    if (this.lastMissed) {
      this.missedAt.set(this.index, this.drags);
      let next = this.index - 1;
      if (this.descend) {
        const wanted = this.descend(this.value, rate);
        while (next > 0 && this.steps[next] > wanted) next -= 1;
      }
      this.index = Math.max(0, next);
    } else if (rate >= HOLDS * TARGET_FPS && this.index + 1 < this.steps.length) {
      const missed = this.missedAt.get(this.index + 1);
      if (missed === undefined || this.drags - missed >= RETRY_AFTER) this.index += 1;
    }
    return this.index !== before;
  }
}

// JPEG: the `interactive` frames a second to ask the server for. Larger scales come with lower
// values (more of the period for the renderer); 24 (the target itself) leaves the client half of
// each frame's time, 12 a sixth (a frame may take 42 ms). Not below 12: an animated session's
// stream holds half of N (12 held 14 fps animated on lavapipe, 8 held 8). It starts at 12, what
// held the rate at the largest scale on lavapipe, and moves from there as the page measures.
export const INTERACTIVE_FPS_STEPS = [24, 20, 16, 14, 12];
export class InteractiveRate {
  constructor(start = 12) {
    this.learner = new StepLearner(INTERACTIVE_FPS_STEPS, start);
  }

  get fps() {
    return this.learner.value;
  }

  learn(drag) {
    return this.learner.learn(drag);
  }
}

// Video: the scale of each side of the interaction's stream, 1/4 to 1 in steps of 1/16 (as the
// server's own scales), starting at 1/2. A stream of another size is a new encoder and a key
// frame, so a drag is measured from its second picture on (dragRate). A drag that missed goes
// down by the square root of its rate's share of the target (pixels for rate), at least a step.
export const VIDEO_SCALE_STEPS = Array.from({length: 13}, (_, i) => (4 + i) / 16);
export class InteractiveScale {
  constructor(start = 0.5) {
    this.learner = new StepLearner(VIDEO_SCALE_STEPS, start,
                                   (scale, rate) => scale * Math.sqrt(rate / TARGET_FPS));
  }

  get scale() {
    return this.learner.value;
  }

  // True when the last drag, at the smallest scale there is, did not hold the rate: video at a
  // quarter of each side is as coarse as the page lets it get.
  get cannotHold() {
    return this.learner.lastIndex === 0 && this.learner.lastRate < HOLDS * TARGET_FPS;
  }

  get lastRate() {
    return this.learner.lastRate;
  }

  learn(drag) {
    return this.learner.learn(drag);
  }
}

// What the page has learnt about holding its rate on one renderer, kept in `storage` (the page's
// localStorage) across reloads: the JPEG stream's ?interactive=, the video interaction's scale,
// and whether video could not hold the rate at all here (then the page takes the JPEG stream).
export class LearntInteraction {
  constructor(storage = null, key = 'myriad.interactive') {
    this.storage = storage;
    this.key = key;
    this.device = '';
    this.rate = new InteractiveRate();
    this.scale = new InteractiveScale();
    this.path = '';  // 'jpeg' once video could not hold the rate here
    this.why = '';
  }

  // The figures an earlier page learnt on the renderer named `device`, if any.
  restore(device) {
    this.device = device;
    let saved = null;
    try {
      saved = JSON.parse(this.storage?.getItem(this.key) || 'null');
    } catch {
      // A corrupt entry is the same as none.
    }
    if (!saved || saved.device !== device) return;
    this.rate = new InteractiveRate(saved.fps);
    this.scale = new InteractiveScale(saved.scale);
    this.path = saved.path === 'jpeg' ? 'jpeg' : '';
    this.why = this.path ? String(saved.why || '') : '';
  }

  // One drag on the stream of `mode` ('video' or 'jpeg'): {changed} when the stream should be
  // asked for differently, {jpeg: why} when video cannot hold the rate here.
  learn(mode, drag) {
    const changed = mode === 'video' ? this.scale.learn(drag) : this.rate.learn(drag);
    let jpeg = '';
    if (mode === 'video' && this.scale.cannotHold) {
      this.path = 'jpeg';
      jpeg = this.why = `video held ${this.scale.lastRate.toFixed(1)} frames a second (not ${TARGET_FPS}) ` +
                        `while dragging at 1/4 size here; the JPEG stream's frames shrink while the view moves`;
    }
    if (changed || jpeg) this.save();
    return {changed, jpeg};
  }

  // The session's lights animate and the stream of `mode` showed `fps` pictures a second of it
  // (over a few seconds): the JPEG stream holds half of its N while lights animate, at a learnt
  // scale; a full-size video stream that shows less than that share of the animation rate cannot
  // hold it here. The why, or ''.
  animated(mode, fps) {
    if (mode !== 'video' || !(fps < MISSES * ANIMATED_FPS)) return '';
    this.path = 'jpeg';
    this.why = `video showed ${fps.toFixed(1)} frames a second of the animation here; the JPEG ` +
               `stream's frames shrink while the lights animate`;
    this.save();
    return this.why;
  }

  save() {
    try {
      this.storage?.setItem(this.key, JSON.stringify({device: this.device, fps: this.rate.fps,
                                                      scale: this.scale.scale, path: this.path,
                                                      why: this.why}));
    } catch {
      // Storage refused (a private window): learnt again next time.
    }
  }
}

// The size of an encoded image from its own header (JPEG SOFn, PNG IHDR): what a stream's part
// shows, without decoding it. null when the bytes are neither.
export function imageSize(bytes) {
  if (bytes.length >= 24 && bytes[0] === 0x89 && bytes[1] === 0x50 && bytes[2] === 0x4e &&
      bytes[3] === 0x47) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.length);
    return {width: view.getUint32(16), height: view.getUint32(20)};
  }
  if (bytes.length < 4 || bytes[0] !== 0xff || bytes[1] !== 0xd8) return null;
  let at = 2;
  while (at + 9 < bytes.length) {
    if (bytes[at] !== 0xff) return null;
    const marker = bytes[at + 1];
    if (marker === 0xff) {  // fill byte
      at += 1;
      continue;
    }
    const length = (bytes[at + 2] << 8) | bytes[at + 3];
    // SOF0..SOF15 but DHT (C4), JPG (C8) and DAC (CC): height, then width.
    if (marker >= 0xc0 && marker <= 0xcf && marker !== 0xc4 && marker !== 0xc8 && marker !== 0xcc) {
      return {height: (bytes[at + 5] << 8) | bytes[at + 6], width: (bytes[at + 7] << 8) | bytes[at + 8]};
    }
    if (marker === 0xda || length < 2) return null;  // the scan starts before any frame header
    at += 2 + length;
  }
  return null;
}

// The stream size for a view of cssWidth x cssHeight CSS pixels: device pixels, capped by what
// the renderer can deliver. A CPU renderer (lavapipe) is asked for CSS pixels (a phone's 3x would
// be 9 times the work for a sharper picture nobody waits for) and at most maxCpuPixels in all;
// any renderer at most maxSide on the longer side (the server's maxResolution).
export function streamSize(cssWidth, cssHeight, {ratio = 1, isCpu = false, maxSide = 4096,
                                                 maxCpuPixels = 1280 * 800, minSide = 16} = {}) {
  const r = isCpu ? Math.min(1, ratio) : ratio;
  let width = Math.max(minSide, Math.round(cssWidth * r));
  let height = Math.max(minSide, Math.round(cssHeight * r));
  let scale = Math.min(1, maxSide / Math.max(width, height));
  if (isCpu) scale = Math.min(scale, Math.sqrt(maxCpuPixels / (width * height)));
  width = Math.max(1, Math.floor(width * scale));
  height = Math.max(1, Math.floor(height * scale));
  return {width, height};
}
