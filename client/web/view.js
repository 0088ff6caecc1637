// The live view: the session's multipart JPEG stream, read with fetch and shown part by part in
// an <img>. The stream is asked for at the view's size in device pixels, with ?interactive=24:
// while the scene changes (a camera drag, a slider, anyone's edit) the server renders cheaper
// frames, their scale chosen from its frame times so that 24 a second hold, marked
// X-Myriad-Interactive (the <img> scales them up to the view), and a full-quality still once the
// changes stop; one stream throughout, so no frame is lost to a reconnect. perf.js measures what
// that feels like (window.myriadPerf).
//
// A video stream keeps its size (its encoder's), so in video mode the page itself asks for a
// half-size stream while the camera moves and ~300 ms after the input stops for the full size.
//
// Video: where the browser decodes it (WebCodecs, in a secure context), the stream is VP9 video
// (?codec=vp9, protocol/reference.md "Video streams") decoded into a <canvas id="video"> over the
// <img>: far fewer bytes than JPEG at the same size (docs/performance.md). The page falls back to the JPEG stream where
// VideoDecoder is missing or cannot decode it, and when the page's address says ?stream=jpeg
// (?stream=vp8 asks for VP8). #view's data-codec says which is in use (vp8, vp9 or jpeg) and
// data-codec-why why JPEG was chosen.
//
// Why fetch and not <img src=stream>: an <img> shows a part only once the next part's headers
// arrive (so a still stayed one part, up to the server's 2 s re-send, behind), gives no event
// when a stream ends or stalls after its first part (the view froze without a word), and needs
// the token in the URL. Here each part is shown as soon as its last byte is in, a stream that
// ends or goes silent is reopened, and the token travels in the Authorization header.

import {ApiError, SessionLostError} from './api.js';
import {MultipartReader, multipartBoundary} from './multipart.js';
import {ViewPerf} from './perf.js';
import {VideoChunkReader, VideoPlayer, videoSupport} from './video.js';

const FULL_QUALITY = 90;
const INTERACTIVE_QUALITY = 60;
const INTERACTIVE_SCALE = 0.5;  // video: of each side, a quarter of the pixels while moving
const SETTLE_MS = 300;          // video: input pause after which the full-quality view returns
// JPEG: the frames a second the server holds while the scene changes (?interactive=).
const INTERACTIVE_FPS = 24;
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
// The video codecs the page can ask for, with the WebCodecs codec string of the server's encoder.
const VIDEO_CODECS = {vp8: 'vp8', vp9: 'vp09.00.10.08'};
// VP9: better pictures than VP8 at the same bitrate, and an encoder whose threads do not spin
// (docs/performance.md, "Stream bandwidth").
const DEFAULT_CODEC = 'vp9';

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
    this.mode = null;               // 'video' or 'jpeg', once chooseMode() decided
    this.codec = 'jpeg';            // 'vp8', 'vp9' or 'jpeg'
    this.canvas = null;             // <canvas id="video"> in video mode
    this.bytesReceived = 0;         // stream bytes so far, all streams (for a bandwidth figure)
    this.framesShown = 0;           // pictures shown so far
    this.ready = this.chooseMode();
    this.perf = new ViewPerf();
    this.loading = new Map();       // object URL -> the shown() figures of the part it holds
    // The newest part that came while the <img> was still loading the one before ({stream,
    // part}): it goes to the <img> once that one has loaded (presentHeld), and a newer part
    // replaces it. Given at once, it cancelled the load under way: on lavapipe 10-20% of a drag's
    // parts were made into Blobs and object URLs and loaded part way, and never shown.
    this.held = null;
    this.onConnect = () => {};      // a stream is being opened
    this.onFrame = () => {};        // ({id, bytes, codec}) a frame was delivered
    this.onInput = () => {};        // camera input: the picture is about to change

    this.img.addEventListener('load', () => {
      // The newest part shows: the parts before it are no longer needed.
      const shown = this.img.src;
      const figures = this.loading.get(shown);
      if (figures) {
        this.perf.shown({...figures, width: this.img.naturalWidth, height: this.img.naturalHeight});
      }
      this.loading.clear();
      for (const url of this.urls.filter((u) => u !== shown)) URL.revokeObjectURL(url);
      this.urls = this.urls.filter((u) => u === shown);
      // Written only when it changes: each write is a style, layout and paint pass of the page.
      const text = `${this.img.naturalWidth}\u00d7${this.img.naturalHeight} JPEG` +
                   (this.interactive || this.img.dataset.interactive ? ' (moving)' : '');
      if (this.status.textContent !== text) this.status.textContent = text;
      this.presentHeld();
    });
    // A part the <img> cannot decode: nothing shows it; the next part may.
    this.img.addEventListener('error', () => {
      this.loading.clear();
      this.presentHeld();
    });

    // Drags for perf.js: on the view (the camera) and on any slider of the page.
    const isSlider = (e) => e.target instanceof HTMLInputElement && e.target.type === 'range';
    this.element.addEventListener('pointerdown', () => this.perf.dragStart());
    this.element.addEventListener('pointerup', () => this.perf.release());
    this.element.addEventListener('pointercancel', () => this.perf.release());
    document.addEventListener('pointerdown', (e) => { if (isSlider(e)) this.perf.dragStart(); });
    document.addEventListener('input', (e) => { if (isSlider(e)) this.perf.change(); });
    document.addEventListener('change', (e) => { if (isSlider(e)) this.perf.release(); });

    let resizeTimer = 0;
    new ResizeObserver(() => {
      clearTimeout(resizeTimer);
      resizeTimer = setTimeout(() => this.restart(), RESIZE_DEBOUNCE_MS);
    }).observe(this.element);
  }

  // Video when this browser decodes it, else JPEG (see the top of this file).
  async chooseMode() {
    const asked = new URLSearchParams(globalThis.location?.search || '').get('stream');
    let why = '';
    if (asked === 'jpeg') {
      why = 'asked for by ?stream=jpeg';
    } else {
      const codec = asked in VIDEO_CODECS ? asked : DEFAULT_CODEC;
      const support = await videoSupport(VIDEO_CODECS[codec]);
      if (support.supported) {
        this.mode = 'video';
        this.codec = codec;
        this.canvas = document.createElement('canvas');
        this.canvas.id = 'video';
        this.canvas.setAttribute('aria-label', "The session's live video");
        this.img.after(this.canvas);
        this.element.dataset.codec = codec;
        return;
      }
      why = support.why;
    }
    this.mode = 'jpeg';
    this.codec = 'jpeg';
    this.element.dataset.codec = 'jpeg';
    this.element.dataset.codecWhy = why;
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
    if (!this.interactive || this.mode !== 'video') return {...full, quality: FULL_QUALITY};
    return {
      width: Math.max(MIN_SIDE, Math.round(full.width * INTERACTIVE_SCALE)),
      height: Math.max(MIN_SIDE, Math.round(full.height * INTERACTIVE_SCALE)),
      quality: INTERACTIVE_QUALITY,
    };
  }

  // (Re)opens the stream when what it should show changed; the old one is closed first.
  restart() {
    if (!this.api.hasSession) return;
    if (!this.mode) {
      this.ready.then(() => this.restart());
      return;
    }
    const p = this.streamParams();
    // Video takes no quality: its bitrate follows the size (the server's default).
    const query = this.mode === 'video'
        ? {target: this.target, codec: this.codec, fps: STREAM_FPS, width: p.width, height: p.height}
        : {target: this.target, format: 'jpeg', fps: STREAM_FPS,
           width: p.width, height: p.height, quality: p.quality, interactive: INTERACTIVE_FPS};
    // The stream's address without the token (data-stream: what the view asks for now).
    const key = `${this.api.sessionPath('/stream')}?${new URLSearchParams(query)}`;
    // The same stream, open or waiting for its retry: nothing to do (and the retry stays due).
    if (this.stream && this.stream.key === key) return;
    clearTimeout(this.retryTimer);
    this.close();
    const stream = {key, abort: new AbortController()};
    this.stream = stream;
    this.img.dataset.stream = key;
    if (this.canvas) this.canvas.dataset.stream = key;
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
    delete this.img.dataset.interactive;
    for (const url of this.urls) URL.revokeObjectURL(url);
    this.urls = [];
    this.loading.clear();
    this.held = null;
    if (this.canvas) {
      this.canvas.width = 0;  // nothing of the old session stays on screen
      delete this.canvas.dataset.stream;
      delete this.canvas.dataset.shown;
      delete this.canvas.dataset.frame;
    }
  }

  close() {
    if (this.stream) this.stream.abort.abort();
    this.stream = null;
  }

  setTarget(target) {
    this.target = target;
    this.restart();
  }

  // Called on every camera input. JPEG: the server makes the frames cheaper while the camera
  // moves. Video: smaller frames now, the full-quality view once input pauses.
  noteInput() {
    this.onInput();
    this.perf.change();
    if (this.mode !== 'video') return;
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
    const video = this.mode === 'video' ? this.startVideo(stream, response) : null;
    const parts = video || new MultipartReader(
        multipartBoundary(response.headers.get('content-type')) || 'myriad-frame');
    let silence = 0;
    let lastPart = 0;
    let longestGap = 0;
    try {
      for (;;) {
        const {done, value} = await reader.read();
        if (done || !current()) break;
        this.bytesReceived += value.length;
        const got = parts.feed(value);
        if (!got.length) continue;
        // Images: only the newest part matters. Video: the player has each chunk already.
        if (!video) this.show(stream, got[got.length - 1]);
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
      stream.player?.close();
    }
    // Ended by the server (session deleted, server stopping) or gone silent: open it again; the
    // new request says why if it cannot be (a lost session, an unreachable server).
    if (current()) {
      this.status.textContent = 'The stream stopped; reconnecting.';
      this.retryLater(stream);
    }
  }

  // A video stream's reader: chunks in, each handed to a decoder that draws on the canvas. A
  // decoder error ends the stream; read() then opens a new one, which starts with a key frame.
  startVideo(stream, response) {
    const chunks = new VideoChunkReader();
    const codec = response.headers.get('x-myriad-codec') || VIDEO_CODECS[this.codec];
    stream.player = new VideoPlayer(this.canvas, codec, {
      onPicture: (chunk) => this.showPicture(stream, chunk),
      onError: (e) => {
        console.warn(`video: ${e.message}`);
        stream.abort.abort();
      },
    });
    return {
      feed: (bytes) => {
        const got = chunks.feed(bytes);
        for (const chunk of got) stream.player.push(chunk);
        return got;
      },
    };
  }

  // A decoded video picture is on the canvas: as show() for an image.
  showPicture(stream, chunk) {
    if (this.stream !== stream) return;
    this.canvas.dataset.shown = stream.key;
    this.canvas.dataset.frame = String(chunk.sequence);
    this.framesShown += 1;
    // The half-size stream of a moving camera counts as interactive, at its scale.
    const fullWidth = this.fullSize().width;
    this.perf.shown({id: `${stream.key}#${chunk.sequence}`,
                     interactive: chunk.width < fullWidth ? chunk.width / fullWidth : 0,
                     width: chunk.width, height: chunk.height});
    this.onFrame({id: `${stream.key}#${chunk.sequence}`, bytes: chunk.payload.byteLength,
                  codec: this.codec});
    this.status.textContent = `${chunk.width}\u00d7${chunk.height} ${this.codec.toUpperCase()}` +
                              (this.interactive ? ' (moving)' : '');
    this.noteShown();
  }

  noteShown() {
    this.retryDelayMs = FIRST_RETRY_MS;
    if (this.troubled) {
      this.troubled = false;
      this.onRecovered();
    }
  }

  // A part arrived: to the <img> now, or once the part it is loading has loaded (this.held).
  show(stream, part) {
    this.framesShown += 1;
    this.onFrame({id: `${stream.key}#${part.headers['x-myriad-frame'] || ''}`,
                  bytes: part.body.byteLength, codec: this.codec});
    this.noteShown();
    if (this.loading.size > 0) {
      this.held = {stream, part};
      return;
    }
    this.present(stream, part);
  }

  presentHeld() {
    const held = this.held;
    this.held = null;
    if (held && held.stream === this.stream) this.present(held.stream, held.part);
  }

  // Gives one part to the <img>. data-shown names the stream it came from, data-frame its
  // X-Myriad-Frame number and data-interactive its X-Myriad-Interactive render scale (empty for
  // a full-quality frame), for whoever inspects the page (the browser test does).
  present(stream, part) {
    const url = URL.createObjectURL(new Blob([part.body], {type: part.headers['content-type']}));
    this.urls.push(url);
    this.img.src = url;
    this.img.dataset.shown = stream.key;
    this.img.dataset.frame = part.headers['x-myriad-frame'] || '';
    this.img.dataset.interactive = part.headers['x-myriad-interactive'] || '';
    this.loading.set(url, {id: `${stream.key}#${this.img.dataset.frame}`,
                           interactive: Number(this.img.dataset.interactive) || 0});
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
