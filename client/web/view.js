// The live view: the session's multipart JPEG stream, read with fetch and shown part by part in
// an <img>. The stream is asked for at the view's size in device pixels; while the camera moves it
// is asked for smaller and at lower quality (a CPU renderer answers much sooner), and ~300 ms after
// the input stops at full size and quality 90 again, so what stays on screen is a full-quality
// still.
//
// Why fetch and not <img src=stream>: an <img> shows a part only once the next part's headers
// arrive (so a still stayed one part, up to the server's 2 s re-send, behind), gives no event
// when a stream ends or stalls after its first part (the view froze without a word), and needs
// the token in the URL. Here each part is shown as soon as its last byte is in, a stream that
// ends or goes silent is reopened, and the token travels in the Authorization header.

import {ApiError, SessionLostError} from './api.js';
import {MultipartReader, multipartBoundary} from './multipart.js';

const FULL_QUALITY = 90;
const INTERACTIVE_QUALITY = 60;
const INTERACTIVE_SCALE = 0.5;  // of each side: a quarter of the pixels while moving
const SETTLE_MS = 300;          // input pause after which the full-quality view returns
const RESIZE_DEBOUNCE_MS = 200;
const STREAM_FPS = 30;
const MIN_SIDE = 16;
// The server writes at least every 2 s (it re-sends the last image while nothing changes), but
// a CPU renderer may need many seconds for one frame of a huge scene. So a stream is taken for
// dead and reopened only once it has shown a part and then stays silent for 30 s or four times
// the longest gap between its parts so far, whichever is longer.
const SILENT_STREAM_MS = 30000;
const SILENT_GAPS = 4;
const FIRST_RETRY_MS = 1000;
const LAST_RETRY_MS = 10000;

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
    this.retryDelayMs = FIRST_RETRY_MS;
    this.retryTimer = 0;
    this.stream = null;        // {key, abort} of the open stream
    this.urls = [];            // object URLs of parts given to the <img>, oldest first
    this.onProblem = () => {};      // (ApiError) => void
    this.onRecovered = () => {};    // a part shows again after onProblem
    this.troubled = false;          // onProblem was called and no part has shown since
    this.codec = 'jpeg';            // how the frames shown are encoded (the stats strip says it)
    this.onConnect = () => {};      // a stream is being opened
    this.onFrame = () => {};        // ({id, bytes, codec}) a frame was delivered
    this.onInput = () => {};        // camera input: the picture is about to change

    this.img.addEventListener('load', () => {
      // The newest part shows: the parts before it are no longer needed.
      const shown = this.img.src;
      for (const url of this.urls.filter((u) => u !== shown)) URL.revokeObjectURL(url);
      this.urls = this.urls.filter((u) => u === shown);
      this.status.textContent = `${this.img.naturalWidth}\u00d7${this.img.naturalHeight}` +
                                (this.interactive ? ' (moving)' : '');
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

  // (Re)opens the stream when what it should show changed; the old one is closed first.
  restart() {
    if (!this.api.hasSession) return;
    const p = this.streamParams();
    const query = {target: this.target, format: 'jpeg', fps: STREAM_FPS,
                   width: p.width, height: p.height, quality: p.quality};
    // The stream's address without the token (data-stream: what the view asks for now).
    const key = `${this.api.sessionPath('/stream')}?${new URLSearchParams(query)}`;
    // The same stream, open or waiting for its retry: nothing to do (and the retry stays due).
    if (this.stream && this.stream.key === key) return;
    clearTimeout(this.retryTimer);
    this.close();
    const stream = {key, abort: new AbortController()};
    this.stream = stream;
    this.img.dataset.stream = key;
    this.onConnect();
    this.read(stream, query);
  }

  stop() {
    clearTimeout(this.retryTimer);
    this.close();
    this.img.removeAttribute('src');
    delete this.img.dataset.stream;
    delete this.img.dataset.shown;
    delete this.img.dataset.frame;
    for (const url of this.urls) URL.revokeObjectURL(url);
    this.urls = [];
  }

  close() {
    if (this.stream) this.stream.abort.abort();
    this.stream = null;
  }

  setTarget(target) {
    this.target = target;
    this.restart();
  }

  // Called on every camera input: smaller frames now, the full-quality view once input pauses.
  noteInput() {
    this.onInput();
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

  // Reads one stream until it ends, stalls, fails or is replaced.
  async read(stream, query) {
    const current = () => this.stream === stream;
    let response;
    try {
      response = await this.api.request('GET', this.api.sessionPath('/stream'),
                                        {raw: true, query, signal: stream.abort.signal});
    } catch (e) {
      if (!current() || e.stale) return;
      if (e instanceof SessionLostError) {
        this.close();
        this.onProblem(e);
        return;  // only a new session helps; no retry
      }
      if (e instanceof ApiError) {
        this.troubled = true;
        this.onProblem(e);
      }
      this.retryLater(stream);
      return;
    }

    const reader = response.body.getReader();
    const parts = new MultipartReader(multipartBoundary(response.headers.get('content-type')) ||
                                      'myriad-frame');
    let silence = 0;
    let lastPart = 0;
    let longestGap = 0;
    try {
      for (;;) {
        const {done, value} = await reader.read();
        if (done || !current()) break;
        const got = parts.feed(value);
        if (!got.length) continue;
        this.show(stream, got[got.length - 1]);  // only the newest part matters
        const now = performance.now();
        if (lastPart) longestGap = Math.max(longestGap, now - lastPart);
        lastPart = now;
        clearTimeout(silence);
        silence = setTimeout(() => stream.abort.abort(),
                             Math.max(SILENT_STREAM_MS, SILENT_GAPS * longestGap));
      }
    } catch (e) {
      // Aborted (replaced, stopped, or silent too long), the connection broke, or a bad part.
      if (current() && !stream.abort.signal.aborted) console.warn(`stream: ${e.message}`);
    } finally {
      clearTimeout(silence);
      reader.cancel().catch(() => {});
    }
    // Ended by the server (session deleted, server stopping) or gone silent: open it again; the
    // new request says why if it cannot be (a lost session, an unreachable server).
    if (current()) {
      this.status.textContent = 'The stream stopped; reconnecting.';
      this.retryLater(stream);
    }
  }

  // Gives one part to the <img>. data-shown names the stream it came from and data-frame its
  // X-Myriad-Frame number, for whoever inspects the page (the browser test does).
  show(stream, part) {
    const url = URL.createObjectURL(new Blob([part.body], {type: part.headers['content-type']}));
    this.urls.push(url);
    this.img.src = url;
    this.img.dataset.shown = stream.key;
    this.img.dataset.frame = part.headers['x-myriad-frame'] || '';
    this.onFrame({id: `${stream.key}#${this.img.dataset.frame}`, bytes: part.body.byteLength,
                  codec: this.codec});
    this.retryDelayMs = FIRST_RETRY_MS;
    if (this.troubled) {
      this.troubled = false;
      this.onRecovered();
    }
  }

  // Opens the stream again after a growing delay: a 429 (too many streams), a restarting server
  // or a busy renderer passes.
  retryLater(stream) {
    clearTimeout(this.retryTimer);
    this.retryTimer = setTimeout(() => {
      if (this.stream !== stream) return;  // replaced meanwhile
      this.stream = null;
      this.restart();
    }, this.retryDelayMs);
    this.retryDelayMs = Math.min(this.retryDelayMs * 2, LAST_RETRY_MS);
  }
}
