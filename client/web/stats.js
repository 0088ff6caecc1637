// Stats: GET stats about twice a second; per-pass GPU times as numbers and as a rolling stacked
// graph, frame time, readback and encode, light counts, the light lists' overflow counters.

import {SessionLostError} from './api.js';

const POLL_MS = 500;
const MAX_POLL_MS = 10000;
const HISTORY = 120;  // samples in the graph: a minute at two a second
const PALETTE = ['#5fa8ff', '#ffb454', '#7fd962', '#ff7a6b', '#c792ea', '#4dd0e1', '#f07178',
                 '#ffd866', '#a6accd', '#89ddff'];

export class StatsPanel {
  constructor(api, canvas, table, {onProblem, onRecovered, onStats = () => {}}) {
    this.api = api;
    this.canvas = canvas;
    this.table = table;
    this.onProblem = onProblem;
    this.onRecovered = onRecovered;  // the server answers again after a failure
    this.onStats = onStats;          // (stats) each answer, for the panels that show a cost
    this.history = [];          // [{passes: Map(name -> ms)}]
    this.colors = new Map();    // pass name -> colour, stable for the page's life
    this.lastFrames = -1;
    this.timer = 0;
    this.generation = 0;
    this.latest = null;
    this.failures = 0;
  }

  start() {
    // A new loop each start; one still waiting on an answer for the previous session ends.
    this.generation += 1;
    clearTimeout(this.timer);
    this.poll(this.generation);
  }

  stop() {
    this.generation += 1;
    clearTimeout(this.timer);
  }

  async poll(generation) {
    let delay = POLL_MS;
    if (!document.hidden) {
      try {
        const stats = await this.api.get(this.api.sessionPath('/stats'));
        if (generation !== this.generation) return;
        this.show(stats);
        if (this.failures) this.onRecovered();
        this.failures = 0;
      } catch (e) {
        if (generation !== this.generation) return;
        if (e instanceof SessionLostError) {
          this.onProblem(e);
          return;
        }
        // Said once; then asked again less and less often until the server answers.
        if (this.failures++ === 0) this.onProblem(e);
        delay = Math.min(POLL_MS * 2 ** this.failures, MAX_POLL_MS);
      }
    }
    if (generation === this.generation) this.timer = setTimeout(() => this.poll(generation), delay);
  }

  colorOf(name) {
    if (!this.colors.has(name)) this.colors.set(name, PALETTE[this.colors.size % PALETTE.length]);
    return this.colors.get(name);
  }

  show(stats) {
    this.latest = stats;
    this.onStats(stats);
    // A sample per new frame only: an idle stream does not flatten the graph into the past.
    if (stats.frame && stats.frames !== this.lastFrames) {
      this.lastFrames = stats.frames;
      this.history.push(new Map(stats.frame.passes.map((p) => [p.name, p.ms])));
      if (this.history.length > HISTORY) this.history.shift();
    }
    this.renderTable(stats);
    this.renderGraph();
  }

  renderTable(stats) {
    const rows = [];
    const row = (label, value, color, warn = false) => rows.push({label, value, color, warn});
    const ms = (x) => (typeof x === 'number' ? `${x.toFixed(3)} ms` : '\u2013');
    const f = stats.frame;
    if (f) {
      for (const pass of f.passes) row(pass.name, ms(pass.ms), this.colorOf(pass.name));
      row('GPU total', ms(f.totalGpuMs));
      if (!f.passes.some((p) => p.name === 'readback')) row('readback', ms(f.readbackMs));
      row('encode', ms(f.encodeMs));
      row('frame', `${f.width}\u00d7${f.height} ${f.technique} ${f.target}`);
    } else {
      row('frame', 'none rendered yet');
    }
    row('frames', String(stats.frames));
    if (stats.lights) {
      row('lights', `${stats.lights.count}${stats.lights.animated ? ' (animated)' : ''}`);
    }
    // The culling report's members depend on the technique: show every number it has, and
    // any overflow counter above zero as a warning (lights were dropped from a list).
    for (const [key, value] of flatten(stats.culling)) {
      row(key, formatNumber(value), undefined, /overflow/i.test(key) && value > 0);
    }
    for (const [key, value] of flatten(stats.gpuMemory)) {
      row(key, typeof value === 'number' ? `${(value / 1048576).toFixed(2)} MiB` : String(value));
    }

    // The same rows as last time (the usual case: a new frame's figures): only the values that
    // changed are written, instead of a new table the page lays out and paints again twice a
    // second, on the cores a CPU renderer shares with it.
    const body = this.table.tBodies[0];
    const same = body.rows.length === rows.length &&
                 rows.every((r, i) => body.rows[i].dataset.stat === r.label &&
                                      body.rows[i].dataset.warn === String(r.warn));
    if (same) {
      rows.forEach(({value}, i) => {
        const cell = body.rows[i].cells[1];
        if (cell.textContent !== value) cell.textContent = value;
      });
      return;
    }
    body.replaceChildren(...rows.map(({label, value, color, warn}) => {
      const tr = document.createElement('tr');
      const name = document.createElement('td');
      if (color) {
        const key = document.createElement('span');
        key.className = 'key';
        key.style.background = color;
        name.append(key);
      }
      name.append(label);
      const cell = document.createElement('td');
      cell.textContent = value;
      if (warn) tr.style.color = 'var(--error)';
      tr.dataset.stat = label;
      tr.dataset.warn = String(warn);
      tr.append(name, cell);
      return tr;
    }));
  }

  // One stacked bar per frame, newest on the right, scaled to the window's slowest frame.
  renderGraph() {
    const c = this.canvas;
    const ratio = window.devicePixelRatio || 1;
    const width = Math.round(c.clientWidth * ratio) || c.width;
    const height = Math.round(c.clientHeight * ratio) || c.height;
    if (c.width !== width) c.width = width;
    if (c.height !== height) c.height = height;
    const g = c.getContext('2d');
    g.clearRect(0, 0, width, height);
    if (!this.history.length) return;
    const totals = this.history.map((m) => [...m.values()].reduce((a, b) => a + b, 0));
    const top = Math.max(...totals, 1e-3) * 1.1;
    const bar = width / HISTORY;
    const scaleY = height / top;
    this.history.forEach((passes, i) => {
      const x = width - (this.history.length - i) * bar;
      let y = height;
      for (const [name, ms] of passes) {
        const h = ms * scaleY;
        g.fillStyle = this.colorOf(name);
        g.fillRect(x, y - h, Math.max(1, bar - ratio), h);
        y -= h;
      }
    });
    g.fillStyle = '#d8dde5';
    g.font = `${11 * ratio}px ui-monospace, monospace`;
    g.fillText(`${(top / 1.1).toFixed(2)} ms`, 4 * ratio, 12 * ratio);
  }
}

function formatNumber(v) {
  if (typeof v !== 'number') return String(v);
  return Number.isInteger(v) ? v.toLocaleString('en') : v.toFixed(3);
}

// {a: 1, b: {c: 2}} -> [["a", 1], ["b.c", 2]]; arrays and null are shown as text.
function flatten(object, prefix = '') {
  if (!object || typeof object !== 'object') return [];
  return Object.entries(object).flatMap(([key, value]) => {
    const name = prefix ? `${prefix}.${key}` : key;
    if (value && typeof value === 'object' && !Array.isArray(value)) return flatten(value, name);
    return [[name, Array.isArray(value) ? JSON.stringify(value) : value]];
  });
}
