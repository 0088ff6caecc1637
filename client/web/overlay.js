// What the view says about itself, on the view: a status line (connecting, waiting for the first
// frame with the seconds counting, "rendering" from the moment of a change until a new frame
// shows) and a stats strip (delivered frames a second, input-to-frame latency, bandwidth, codec).
//
// The live view reports each delivered frame through frame(); the page reports each change
// (camera input, an edit sent) through changed(). Nothing here knows how frames travel: the codec
// is whatever the view says it decodes ("jpeg" for the multipart stream).

const STATS_WINDOW_MS = 2000;   // fps and bandwidth: over the last two seconds
const TICK_MS = 250;            // how often the waiting text and the strip refresh
// A frame that shows the last change hides "rendering" at once only when no change came in this
// long; else the timer's next refresh does. During a drag a move follows each frame within tens
// of milliseconds: the line went away at every frame and came back at the next move, two style,
// layout and paint passes a frame (on lavapipe, on the cores the server renders on).
const CHANGES_KEEP_MS = 100;

export class ViewOverlay {
  constructor(status, strip) {
    this.status = status;   // the status line on the view
    this.strip = strip;     // the stats strip
    this.connectingSince = 0;  // performance.now() of connect(); 0 once a frame showed
    this.changeAt = 0;         // performance.now() of the oldest change no frame shows yet
    this.changeFrame = '';     // the frame shown when that change was made
    this.lastChangeAt = 0;     // performance.now() of the newest change
    this.lastFrame = '';       // "stream key#frame number" of the frame shown last
    this.latencyMs = null;     // the last change's input-to-frame time
    this.codec = '';
    this.frames = [];          // {t, bytes} of the frames delivered in the stats window
    this.firstFrameMs = null;
    this.firstShownAt = 0;
    this.timer = setInterval(() => this.refresh(), TICK_MS);
    this.refresh();
  }

  // A stream is being opened: "connecting" until its first frame.
  connect() {
    if (this.connectingSince === 0 && this.lastFrame === '') this.connectingSince = performance.now();
    this.refresh();
  }

  // Something that changes the picture happened: "rendering" at once, until a new frame shows.
  changed() {
    this.lastChangeAt = performance.now();
    if (!this.changeAt) {
      this.changeAt = performance.now();
      this.changeFrame = this.lastFrame;
    }
    this.show('rendering\u2026', 'rendering');
  }

  // The change was refused: no new frame is coming for it.
  cancelChange() {
    this.changeAt = 0;
    this.refresh();
  }

  // A frame was delivered: `id` names it (a re-send of the same frame keeps its id), `bytes` its
  // size on the wire, `codec` how it is encoded.
  frame({id, bytes, codec}) {
    const now = performance.now();
    this.codec = codec;
    this.frames.push({t: now, bytes});
    if (this.connectingSince) {
      this.firstFrameMs = now - this.connectingSince;
      this.firstShownAt = now;
      this.connectingSince = 0;
    }
    const isNew = id !== this.lastFrame;
    this.lastFrame = id;
    if (this.changeAt && isNew && id !== this.changeFrame) {
      this.latencyMs = now - this.changeAt;
      this.changeAt = 0;
    }
    if (now - this.lastChangeAt >= CHANGES_KEEP_MS) this.refreshState();
  }

  // Called on every camera move and every frame: the DOM is written only when something changed
  // (each write is a style, layout and paint pass of the page).
  show(text, state) {
    if (this.status.textContent !== text) this.status.textContent = text;
    if (this.status.dataset.state !== state) this.status.dataset.state = state;
    if (this.status.hidden !== !text) this.status.hidden = !text;
  }

  // Everything: the status line and the strip (the strip only here, on the timer: written per
  // frame, its fps figure changed with every frame and cost the page a style, layout and paint
  // pass each time, on the cores a CPU renderer shares with it).
  refresh() {
    this.refreshState();
    this.refreshStrip();
  }

  refreshState() {
    const now = performance.now();
    if (this.changeAt) {
      this.show('rendering\u2026', 'rendering');
    } else if (this.connectingSince) {
      const seconds = (now - this.connectingSince) / 1000;
      this.show(seconds < 1 ? 'connecting\u2026'
                            : `waiting for the first frame: ${seconds.toFixed(1)} s`, 'connecting');
    } else if (this.firstFrameMs !== null && now - this.firstShownAt < 3000) {
      this.show(`first frame in ${(this.firstFrameMs / 1000).toFixed(1)} s`, 'shown');
    } else {
      this.show('', 'idle');
    }
  }

  refreshStrip() {
    const now = performance.now();
    this.frames = this.frames.filter((f) => now - f.t <= STATS_WINDOW_MS);
    const seconds = STATS_WINDOW_MS / 1000;
    const fps = this.frames.length / seconds;
    const bits = this.frames.reduce((sum, f) => sum + f.bytes, 0) * 8 / seconds;
    const latency = this.latencyMs === null ? '\u2013' : `${Math.round(this.latencyMs)} ms`;
    const rate = bits >= 1e6 ? `${(bits / 1e6).toFixed(2)} Mbit/s` : `${(bits / 1e3).toFixed(0)} kbit/s`;
    const fields = {fps: fps.toFixed(1), latency, bandwidth: rate, codec: this.codec || '\u2013'};
    for (const [name, value] of Object.entries(fields)) {
      const cell = this.strip.querySelector(`[data-stat="${name}"]`);
      if (cell && cell.textContent !== value) cell.textContent = value;
    }
    const data = {fps: fps.toFixed(2),
                  latencyMs: this.latencyMs === null ? '' : String(Math.round(this.latencyMs)),
                  bitsPerSecond: String(Math.round(bits)), codec: String(this.codec)};
    for (const [name, value] of Object.entries(data)) {
      if (this.strip.dataset[name] !== value) this.strip.dataset[name] = value;
    }
  }
}

// A one-line hint on the view for someone who has not used it yet: what dragging, the wheel and
// the keys do, shown until the camera first moves; on an empty scene (no objects) what fills it,
// shown until something does.
const HINT_TEXT = 'Drag to orbit \u00b7 right-drag to pan \u00b7 wheel or +/\u2212 to zoom \u00b7 ' +
                  'arrow keys orbit \u00b7 ? for help';
const EMPTY_TEXT = 'The scene is empty: drop a model file here, or use Upload in the Model panel.';

export class ViewHint {
  constructor(element) {
    this.element = element;
    this.moved = false;
    this.empty = false;
    this.render();
  }

  // The camera moved: the user has found the view.
  used() {
    if (this.moved) return;
    this.moved = true;
    this.render();
  }

  setObjects(count) {
    this.empty = count === 0;
    this.render();
  }

  render() {
    const text = this.empty ? EMPTY_TEXT : this.moved ? '' : HINT_TEXT;
    if (this.element.textContent !== text) this.element.textContent = text;
    this.element.hidden = !text;
    this.element.dataset.state = this.empty ? 'empty' : 'hint';
  }
}
