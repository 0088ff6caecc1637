// The live view: an <img> showing the session's multipart JPEG stream. The stream is asked for at
// the view's size in device pixels; while the camera moves it is asked for smaller and at lower
// quality (a CPU renderer answers much sooner), and ~300 ms after the input stops at full size
// and quality 90 again, so what stays on screen is a full-quality still.

import {ApiError, SessionLostError} from './api.js';

const FULL_QUALITY = 90;
const INTERACTIVE_QUALITY = 60;
const INTERACTIVE_SCALE = 0.5;  // of each side: a quarter of the pixels while moving
const SETTLE_MS = 300;          // input pause after which the full-quality view returns
const RESIZE_DEBOUNCE_MS = 200;
const STREAM_FPS = 30;
const MIN_SIDE = 16;

export class LiveView {
  constructor(api, element, img, status) {
    this.api = api;
    this.element = element;
    this.img = img;
    this.status = status;
    this.target = 'final';
    this.maxResolution = 4096;
    this.interactive = false;
    this.settleTimer = 0;
    this.retryDelayMs = 1000;
    this.retryTimer = 0;
    this.onProblem = () => {};      // (ApiError) => void

    this.img.addEventListener('load', () => {
      this.img.classList.remove('failed');
      this.retryDelayMs = 1000;
      this.status.textContent = `${this.img.naturalWidth}\u00d7${this.img.naturalHeight}` +
                                (this.interactive ? ' (moving)' : '');
    });
    this.img.addEventListener('error', () => {
      this.img.classList.add('failed');  // no broken-image icon over the view
      this.streamFailed();
    });

    let resizeTimer = 0;
    new ResizeObserver(() => {
      clearTimeout(resizeTimer);
      resizeTimer = setTimeout(() => this.restart(), RESIZE_DEBOUNCE_MS);
    }).observe(this.element);
  }

  // The full-quality size: the element's size in device pixels, scaled down to the server's
  // maxResolution on the longer side.
  fullSize() {
    const ratio = window.devicePixelRatio || 1;
    let width = Math.max(MIN_SIDE, Math.round(this.element.clientWidth * ratio));
    let height = Math.max(MIN_SIDE, Math.round(this.element.clientHeight * ratio));
    const scale = Math.min(1, this.maxResolution / Math.max(width, height));
    width = Math.max(1, Math.floor(width * scale));
    height = Math.max(1, Math.floor(height * scale));
    return {width, height};
  }

  streamParams() {
    const full = this.fullSize();
    if (!this.interactive) return {...full, quality: FULL_QUALITY};
    return {
      width: Math.max(MIN_SIDE, Math.round(full.width * INTERACTIVE_SCALE)),
      height: Math.max(MIN_SIDE, Math.round(full.height * INTERACTIVE_SCALE)),
      quality: INTERACTIVE_QUALITY,
    };
  }

  // (Re)starts the stream when its URL changed; a new src closes the old connection.
  restart() {
    if (!this.api.hasSession) return;
    clearTimeout(this.retryTimer);
    const p = this.streamParams();
    const url = this.api.sessionImageUrl('/stream', {
      target: this.target, format: 'jpeg', fps: STREAM_FPS,
      width: p.width, height: p.height, quality: p.quality,
    });
    if (this.img.getAttribute('src') === url) return;
    this.img.src = url;
  }

  stop() {
    clearTimeout(this.retryTimer);
    this.img.removeAttribute('src');
  }

  setTarget(target) {
    this.target = target;
    this.restart();
  }

  // Called on every camera input: smaller frames now, the full-quality view once input pauses.
  noteInput() {
    if (!this.interactive) {
      this.interactive = true;
      this.restart();
    }
    clearTimeout(this.settleTimer);
    this.settleTimer = setTimeout(() => {
      this.interactive = false;
      this.restart();
    }, SETTLE_MS);
  }

  // An <img> does not say why it failed; the same request through fetch does (its problem
  // body), and is dropped as soon as the status is known.
  async streamFailed() {
    const url = this.img.getAttribute('src');
    if (!url) return;
    const abort = new AbortController();
    try {
      await this.api.request('GET', url, {raw: true, signal: abort.signal});
      this.status.textContent = 'The stream stopped; reconnecting.';
    } catch (e) {
      if (this.img.getAttribute('src') !== url) return;  // replaced meanwhile: not ours to fix
      if (e instanceof SessionLostError) {
        this.onProblem(e);
        return;  // only a new session helps; no retry
      }
      if (e instanceof ApiError) this.onProblem(e);
    } finally {
      abort.abort();
    }
    // Retry with a growing delay: a 429 (too many streams) or a restarting server passes.
    this.retryTimer = setTimeout(() => {
      this.img.removeAttribute('src');
      this.restart();
    }, this.retryDelayMs);
    this.retryDelayMs = Math.min(this.retryDelayMs * 2, 10000);
  }
}
