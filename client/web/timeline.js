// The timeline: the session's scene clock (GET, PATCH .../clock), on which the objects play their
// animation clips. Shown while the scene has something to play (the clock's duration > 0): play
// or pause, a slider over the longest clip (the clock's time wrapped into it) to scrub, and the
// rate. Which clip an object plays is chosen in its editor in the Objects panel. While the clock
// plays, the slider follows it: moved on from the last answer every TICK_MS and read again every
// POLL_MS. The session's events say when someone changes the clock, not where it has got to.

import {PatchSender} from './sender.js';

const $ = (id) => document.getElementById(id);
const TICK_MS = 100;
const POLL_MS = 1000;
const SEND_INTERVAL_MS = 80;  // scrubbing: at most ~12 seeks a second, the newest time

export class TimelinePanel {
  constructor(api, {onProblem}) {
    this.api = api;
    this.onProblem = onProblem;
    this.clock = null;      // the last answer: {time, playing, rate, duration}
    this.readAt = 0;        // performance.now() when it came
    this.polledAt = 0;      // ... when it was last asked for while playing
    this.timer = 0;
    this.scrubbing = false;  // the slider is being moved: it shows the user's time, not the clock's
    this.edits = 0;          // patches queued: a read sent before the last of them is out of date
    this.sender = new PatchSender((patch, end) =>
        this.api.patch(this.api.sessionPath('/clock'), patch, end), SEND_INTERVAL_MS);
    this.sender.onAnswer = (clock) => this.show(clock);
    this.sender.onProblem = (e) => {
      this.onProblem(e);
      this.refresh();
    };

    $('timeline-play').addEventListener('click', () => {
      if (this.clock) this.send({playing: !this.clock.playing});
    });
    const scrub = $('timeline-scrub');
    scrub.addEventListener('input', () => {
      this.scrubbing = true;
      this.showTime(scrub.valueAsNumber);
      this.queue({time: scrub.valueAsNumber});
    });
    scrub.addEventListener('change', () => {
      this.scrubbing = false;
      this.send({time: scrub.valueAsNumber});
    });
    $('timeline-rate').addEventListener('change', () => {
      const rate = $('timeline-rate').valueAsNumber;
      if (Number.isFinite(rate)) this.send({rate});
      else this.show(this.clock);  // back to the clock's rate
    });
  }

  queue(patch) {
    ++this.edits;
    this.sender.queue(patch);
  }

  send(patch) {
    this.queue(patch);
    this.sender.end();
  }

  // The clock as the server has it now (after the scene or its clips changed, or to poll).
  // A read while a patch is on its way could be answered from before it: the patch's own answer
  // is the clock then.
  async refresh() {
    if (!this.api.session || this.sender.busy) return;
    const session = this.api.session;
    const edits = this.edits;
    try {
      const clock = await this.api.get(this.api.sessionPath('/clock'));
      if (this.api.session === session && this.edits === edits && !this.sender.busy) this.show(clock);
    } catch (e) {
      clearTimeout(this.timer);  // no polling of a clock that does not answer
      this.timer = 0;
      this.onProblem(e);
    }
  }

  show(clock) {
    clearTimeout(this.timer);
    this.timer = 0;
    this.clock = clock;
    this.readAt = performance.now();
    const panel = $('timeline');
    panel.hidden = !clock || !(clock.duration > 0);
    if (panel.hidden) return;
    const play = $('timeline-play');
    play.textContent = clock.playing ? 'Pause' : 'Play';
    play.setAttribute('aria-pressed', String(clock.playing));
    $('timeline-scrub').max = String(clock.duration);
    if ($('timeline-rate') !== document.activeElement) $('timeline-rate').value = String(clock.rate);
    this.tick();
  }

  // The clock's time now, moved on from the last answer at its rate.
  now() {
    const c = this.clock;
    if (!c.playing) return c.time;
    return Math.max(0, c.time + (c.rate * (performance.now() - this.readAt)) / 1000);
  }

  tick() {
    this.timer = 0;
    if (!this.scrubbing) this.showTime(this.now());
    if (!this.clock.playing || $('timeline').hidden) return;
    const now = performance.now();
    if (now - Math.max(this.readAt, this.polledAt) >= POLL_MS) {
      this.polledAt = now;  // one poll a POLL_MS; its answer starts the ticks again
      this.refresh();
    }
    this.timer = setTimeout(() => this.tick(), TICK_MS);
  }

  // The slider at `time` wrapped into the longest clip; the text says both.
  showTime(time) {
    const duration = this.clock.duration;
    const inClip = time > duration ? time % duration : time;
    const scrub = $('timeline-scrub');
    if (!this.scrubbing) scrub.value = String(inClip);
    scrub.setAttribute('aria-valuetext', `${inClip.toFixed(2)} seconds`);
    const of = `of ${duration.toFixed(2)}`;
    $('timeline-time').textContent =
        `${time.toFixed(2)} s ${time > duration ? `(${inClip.toFixed(2)} ${of})` : of}`;
  }
}
