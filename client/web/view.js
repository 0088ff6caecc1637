// The live view: the session's multipart JPEG stream, read with fetch and shown part by part in
// an <img>. The stream is asked for at the view's size in device pixels, with ?interactive=24:
// while the scene changes (a camera drag, a slider, anyone's edit) the server renders cheaper
// frames, their scale chosen from its frame times so that 24 a second hold, marked
// X-Myriad-Interactive (the <img> scales them up to the view), and a full-quality still once the
// changes stop; one stream throughout, so no frame is lost to a reconnect. perf.js measures what
// that feels like (window.myriadPerf).
//
// A video stream keeps its size (its encoder's), so in video mode the page itself asks for a
// smaller stream while the camera moves and ~300 ms after the input stops for the full size.
// Either way the scale is learnt from the page's own measured frames (adaptive.js): the largest
// that holds the rate. The stream is asked for in device pixels, capped by what the renderer can
// deliver (a CPU renderer gets CSS pixels, at most about 1280x800).
//
// Whatever carries the frames, what the view shows is described by the stream's own metadata
// (this.frame: size, sequence, render scale; a video chunk's header, an image part's headers and
// its JPEG header), never read back from the element that shows it: picking, the overlay's
// "rendering" state, the stats strip and perf.js read it the same way on every path. Each
// stream opened has a serial number of its own, so a new stream's first frame (its sequence
// starts again at 1) is never taken for a re-send of the last stream's.
//
// Video: where the browser decodes it (WebCodecs, in a secure context), the stream is VP9 video
// (?codec=vp9, protocol/reference.md "Video streams") decoded into a <canvas id="video"> over the
// <img>: far fewer bytes than JPEG at the same size (docs/performance.md). Where WebCodecs is
// missing (an http page that is not localhost) or cannot decode it, the same video comes in live
// WebM (?container=webm) and plays in a <video id="video"> through Media Source Extensions
// (mse.js), where the browser's player takes it; else the JPEG stream. Media Source Extensions
// show a picture later than WebCodecs (the element's own pipeline) and say less of it (no
// session version or animation time per picture), hence second choice. The page's address may
// ask: ?stream=jpeg the JPEG stream, ?stream=mse Media Source Extensions (with ?codec=vp8 or
// h264), ?stream=vp8 VP8 (either player), ?stream=h264 H.264 in MP4 (Media Source Extensions
// only: the server sends H.264 in MP4 alone). Once the page measured that video cannot hold the
// rate here even at its smallest interaction scale (adaptive.js; remembered per renderer) it
// takes the JPEG stream. #view's data-codec says which codec is in use (vp8, vp9, h264 or jpeg),
// data-player which player (webcodecs, mse or jpeg; the status line on the view names it too) and
// data-codec-why why the first choice was not taken.
//
// Why fetch and not <img src=stream>: an <img> shows a part only once the next part's headers
// arrive (so a still stayed one part, up to the server's 2 s re-send, behind), gives no event
// when a stream ends or stalls after its first part (the view froze without a word), and needs
// the token in the URL. Here each part is shown as soon as its last byte is in, a stream that
// ends or goes silent is reopened, and the token travels in the Authorization header.

import {LearntInteraction, streamSize} from './adaptive.js';
import {ApiError, SessionLostError, problemMessage} from './api.js';
import {ImagePresenter} from './image.js';
import {MultipartReader, multipartBoundary} from './multipart.js';
import {ViewPerf} from './perf.js';
import {MSE_FORMATS, MsePlayer, mseSupport} from './mse.js';
import {VideoChunkReader, VideoPlayer, videoSupport} from './video.js';

const FULL_QUALITY = 90;
const INTERACTIVE_QUALITY = 60;
const SETTLE_MS = 300;          // video: input pause after which the full-quality view returns
// JPEG: a newly learnt ?interactive= takes a new stream, opened once the view has been still this
// long (never in the middle of a drag).
const ADAPT_IDLE_MS = 1000;
// Video: the animation's rate is judged over this long, once it has run this long.
const ANIMATION_WINDOW_MS = 3000;
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
// (bench/history/performance-2026-11-to-12.md, "Stream bandwidth").
const DEFAULT_CODEC = 'vp9';
// How the status line names each player.
const PLAYER_NAMES = {webcodecs: 'WebCodecs', mse: 'MSE'};

export class LiveView {
  constructor(api, element, img, status) {
    this.api = api;
    this.element = element;
    this.img = img;
    this.status = status;
    this.target = 'final';
    this.maxResolution = 4096;
    this.isCpu = false;        // the renderer is a CPU (lavapipe): streamSize() caps the pixels
    this.interactive = false;
    // What the view shows now, from the stream's metadata: {width, height, sequence, interactive
    // (render scale, 0 for full quality), id}; null before the first picture.
    this.frame = null;
    this.serial = 0;           // streams opened so far: each one's frame ids carry its own
    // JPEG's ?interactive=, video's interaction scale, and the path, as learnt (adaptive.js).
    this.learnt = new LearntInteraction(globalThis.localStorage);
    this.adaptTimer = 0;
    this.lastInputAt = 0;      // performance.now() of the last camera input
    this.onPathChange = () => {};   // (why) the page took the JPEG stream instead of video
    this.animatingSince = 0;        // video: when the pictures began to show animated lights
    this.animationCheckedAt = 0;
    this.settleTimer = 0;
    this.retryDelayMs = FIRST_RETRY_MS;
    this.retryTimer = 0;
    this.stream = null;        // {key, serial, abort} of the open stream
    this.onProblem = () => {};      // (ApiError) => void
    this.onRecovered = () => {};    // a part shows again after onProblem
    this.troubled = false;          // onProblem was called and no part has shown since
    this.mode = null;               // 'video' or 'jpeg', once chooseMode() decided
    this.codec = 'jpeg';            // 'vp8', 'vp9', 'h264' or 'jpeg'
    this.player = 'jpeg';           // video's player: 'webcodecs' or 'mse'; else 'jpeg'
    this.canvas = null;             // <canvas id="video"> in video mode with WebCodecs
    // Media Source Extensions: each stream plays in a <video> of its own (stream.player's),
    // beneath the one shown until it shows its first picture, then in its place as #video: a
    // new stream (a drag's smaller one, its full-size still) never blanks the view.
    this.shownVideo = null;         // the MsePlayer whose <video> is #video
    this.bytesReceived = 0;         // stream bytes so far, all streams (for a bandwidth figure)
    this.framesShown = 0;           // pictures shown so far
    this.ready = this.chooseMode();
    this.perf = new ViewPerf();
    this.perf.onDrag = (drag) => this.learn(drag);
    // The JPEG path's <img>: each part given to it, and told back once it shows.
    this.images = new ImagePresenter(img, (figures) => this.imageShown(figures));
    this.onConnect = () => {};      // a stream is being opened
    this.onFrame = () => {};        // ({id, bytes, codec}) a frame was delivered
    this.onInput = () => {};        // camera input: the picture is about to change

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

  // Video when this browser decodes it (WebCodecs, else Media Source Extensions), else JPEG (see
  // the top of this file).
  async chooseMode() {
    const params = new URLSearchParams(globalThis.location?.search || '');
    const asked = params.get('stream');
    const whys = [];
    if (asked === 'jpeg') {
      whys.push('asked for by ?stream=jpeg');
    } else {
      const mseOnly = asked === 'mse' || asked === 'h264';
      const codec = asked === 'mse' ? (params.get('codec') in MSE_FORMATS ? params.get('codec') : DEFAULT_CODEC)
                                    : asked in MSE_FORMATS ? asked : DEFAULT_CODEC;
      if (asked === 'mse') whys.push('asked for by ?stream=mse');
      else if (codec === 'h264') whys.push('H.264 comes in MP4 only, for Media Source Extensions');
      if (!mseOnly) {
        const support = await videoSupport(VIDEO_CODECS[codec]);
        if (support.supported) {
          this.useVideo(codec, 'webcodecs', '');
          return;
        }
        whys.push(support.why);
      }
      const support = mseSupport(codec);
      if (support.supported) {
        this.useVideo(codec, 'mse', whys.join('; '));
        return;
      }
      whys.push(support.why);
    }
    this.mode = 'jpeg';
    this.codec = 'jpeg';
    this.player = 'jpeg';
    this.element.dataset.codec = 'jpeg';
    this.element.dataset.player = 'jpeg';
    this.element.dataset.codecWhy = whys.join('; ');
  }

  // Video of `codec` played by `player` ('webcodecs': decoded onto a canvas made here; 'mse':
  // each stream's <video> is made as it opens), and why the first choice was not taken.
  useVideo(codec, player, why) {
    this.mode = 'video';
    this.codec = codec;
    this.player = player;
    if (player === 'webcodecs') {
      this.canvas = document.createElement('canvas');
      this.canvas.id = 'video';
      this.canvas.setAttribute('aria-label', "The session's live video");
      this.img.after(this.canvas);
    }
    this.element.dataset.codec = codec;
    this.element.dataset.player = player;
    if (why) this.element.dataset.codecWhy = why;
  }

  // The full-quality size: the element's size in device pixels, capped by what the renderer can
  // deliver (adaptive.js streamSize) and by the server's maxResolution on the longer side.
  fullSize() {
    return streamSize(this.element.clientWidth, this.element.clientHeight, {
      ratio: window.devicePixelRatio || 1, isCpu: this.isCpu, maxSide: this.maxResolution,
      minSide: MIN_SIDE});
  }

  // The size of the frames shown now (the stream's own metadata), {width: 0, height: 0} before
  // the first: what a click on the view is a pixel of.
  frameSize() {
    return this.frame ? {width: this.frame.width, height: this.frame.height} : {width: 0, height: 0};
  }

  streamParams() {
    const full = this.fullSize();
    // H.264 (4:2:0, whole macroblock pairs of chroma) takes even sizes only: the <video> scales
    // the one pixel lost up to the view.
    const even = (side) => (this.codec === 'h264' ? side - (side % 2) : side);
    if (!this.interactive || this.mode !== 'video') {
      return this.mode === 'video' ? {width: even(full.width), height: even(full.height), quality: FULL_QUALITY}
                                   : {...full, quality: FULL_QUALITY};
    }
    const scale = this.learnt.scale.scale;
    return {
      width: even(Math.max(MIN_SIDE, Math.round(full.width * scale))),
      height: even(Math.max(MIN_SIDE, Math.round(full.height * scale))),
      quality: INTERACTIVE_QUALITY,
    };
  }

  // The learnt figures of an earlier page on the same renderer (see adaptive.js); where video
  // could not hold the rate there, the JPEG stream from the start.
  restoreLearnt(device) {
    this.learnt.restore(device);
    if (this.learnt.path !== 'jpeg') return;
    if (this.mode) this.useJpeg(this.learnt.why);
    else this.ready = this.ready.then(() => this.useJpeg(this.learnt.why));
  }

  // Video could not hold the rate here: the JPEG stream instead, and why (#view's data-codec-why)
  // unless the page's address asked for a codec (?stream=vp9 stays video).
  useJpeg(why) {
    if (this.mode !== 'video' || new URLSearchParams(globalThis.location?.search || '').has('stream')) {
      return false;
    }
    this.mode = 'jpeg';
    this.codec = 'jpeg';
    this.player = 'jpeg';
    this.interactive = false;
    clearTimeout(this.settleTimer);
    this.canvas?.remove();
    this.canvas = null;
    this.shownVideo?.dispose();
    this.shownVideo = null;
    this.element.dataset.codec = 'jpeg';
    this.element.dataset.player = 'jpeg';
    this.element.dataset.codecWhy = why;
    if (this.stream) {
      this.close();
      this.restart();
    }
    return true;
  }

  // A drag ended (perf.js's figures): the interactive scale learns from the rate it held.
  // JPEG: a new ?interactive= takes a new stream, opened once the view is still.
  learn(drag) {
    const {changed, jpeg} = this.learnt.learn(this.mode, drag);
    if (jpeg && this.useJpeg(jpeg)) {
      this.onPathChange(jpeg);
      return;
    }
    if (!changed || this.mode === 'video') return;  // the next interaction's stream takes it
    const reopen = () => {
      if (this.perf.drag || performance.now() - this.lastInputAt < ADAPT_IDLE_MS) {
        this.adaptTimer = setTimeout(reopen, ADAPT_IDLE_MS);
        return;
      }
      this.restart();
    };
    clearTimeout(this.adaptTimer);
    this.adaptTimer = setTimeout(reopen, ADAPT_IDLE_MS);
  }

  // (Re)opens the stream when what it should show changed; the old one is closed first.
  restart() {
    if (!this.api.hasSession) return;
    if (!this.mode) {
      this.ready.then(() => this.restart());
      return;
    }
    const p = this.streamParams();
    // Video takes no quality: its bitrate follows the size (the server's default). Media Source
    // Extensions take a standard container (WebCodecs, Myriad's chunks: the default).
    const query = this.mode === 'video'
        ? {target: this.target, codec: this.codec, fps: STREAM_FPS, width: p.width, height: p.height}
        : {target: this.target, format: 'jpeg', fps: STREAM_FPS,
           width: p.width, height: p.height, quality: p.quality, interactive: this.learnt.rate.fps};
    if (this.player === 'mse') query.container = MSE_FORMATS[this.codec].container;
    // The stream's address without the token (data-stream: what the view asks for now).
    const key = `${this.api.sessionPath('/stream')}?${new URLSearchParams(query)}`;
    // The same stream, open or waiting for its retry: nothing to do (and the retry stays due).
    if (this.stream && this.stream.key === key) return;
    clearTimeout(this.retryTimer);
    this.close();
    this.serial += 1;
    const stream = {key, serial: this.serial, abort: new AbortController()};
    this.stream = stream;
    this.images.img.dataset.stream = key;
    if (this.canvas) this.canvas.dataset.stream = key;
    this.onConnect();
    this.read(stream, query);
  }

  stop() {
    clearTimeout(this.retryTimer);
    this.close();
    this.images.clear();
    this.frame = null;
    this.shownVideo?.dispose();  // nothing of the old session stays on screen
    this.shownVideo = null;
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
    this.lastInputAt = performance.now();
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
    const video = this.mode !== 'video' ? null
        : this.player === 'mse' ? this.startMse(stream, response) : this.startVideo(stream, response);
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
        // Images: only the newest part matters. Video: the player has each chunk already. A
        // problem part is the last: the session or the link is gone (said, no retry).
        if (!video) {
          const last = got[got.length - 1];
          if (/problem\+json/.test(last.headers['content-type'] || '')) {
            this.endedBy(stream, last);
            break;
          }
          this.show(stream, last);
        }
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
      // A <video> that shows no picture yet goes now; the one shown stays until the next shows.
      if (stream.player instanceof MsePlayer && stream.player !== this.shownVideo) stream.player.dispose();
      else stream.player?.close();
    }
    // Ended by the server (session deleted, server stopping) or gone silent: open it again; the
    // new request says why if it cannot be (a lost session, an unreachable server).
    if (current()) {
      this.status.textContent = 'The stream stopped; reconnecting.';
      this.retryLater(stream);
    }
  }

  // An image stream's last part said why it ended (a deleted or expired session, a revoked or
  // expired viewer link): said as a refused request would be, and the stream is not reopened.
  endedBy(stream, part) {
    let problem = null;
    try {
      problem = JSON.parse(new TextDecoder().decode(part.body));
    } catch {
      // Unreadable: reopening the stream will say why in its answer.
    }
    const status = Number(problem?.status) || 0;
    if (status !== 401 && status !== 404) return;
    this.close();
    this.onProblem(new SessionLostError(status, problem, problemMessage(status, problem)));
  }

  // A video stream's reader: chunks in, each handed to a decoder that draws on the canvas. A
  // decoder error ends the stream; read() then opens a new one, which starts with a key frame.
  startVideo(stream, response) {
    const chunks = new VideoChunkReader();
    const codec = response.headers.get('x-myriad-codec') || VIDEO_CODECS[this.codec];
    stream.player = new VideoPlayer(this.canvas, codec, {
      onPicture: (chunk) => {
        if (this.stream !== stream) return;
        this.canvas.dataset.shown = stream.key;
        this.canvas.dataset.frame = String(chunk.sequence);
        this.showPicture(stream, chunk, chunk.payload.byteLength);
        this.checkAnimation(chunk);
      },
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

  // A Media Source Extensions stream's reader: its bytes to a <video> of its own (see
  // this.shownVideo), which takes the place of the one shown at its first picture. An error of the
  // element ends the stream; read() then opens a new one. A picture's size and number come from
  // the element's frame callback; the container carries no animation time, so the animated-rate
  // check of the WebCodecs path (checkAnimation) has nothing to judge here (drags still do).
  startMse(stream, response) {
    const format = MSE_FORMATS[this.codec];
    // The response's codec string: H.264's level is the server's choice (size, rate, bitrate).
    const codecs = response.headers.get('x-myriad-codec') || format.codecs;
    const video = document.createElement('video');
    video.setAttribute('aria-label', "The session's live video");
    video.dataset.stream = stream.key;
    this.img.after(video);  // beneath the <video> shown now, which comes later in #view
    const player = new MsePlayer(video, format, `${format.mime}; codecs="${codecs}"`, {
      onPicture: (picture) => {
        if (this.stream !== stream) return;
        if (this.shownVideo !== player) {
          const before = this.shownVideo;
          this.shownVideo = player;
          if (before) before.dispose();  // frees the id before it is taken
          video.id = 'video';
        }
        video.dataset.shown = stream.key;
        video.dataset.frame = String(picture.sequence);
        this.showPicture(stream, picture, picture.bytes);
      },
      onError: (e) => {
        console.warn(`video: ${e.message}`);
        stream.abort.abort();
      },
    });
    stream.player = player;
    return {
      feed: (bytes) => {
        player.feed(bytes);
        return [bytes];  // a keep-alive too: the stream is alive
      },
    };
  }

  // A video picture shows (decoded on the canvas, or presented by the <video>), {width, height,
  // sequence}, with `bytes` of the stream it took: as show() for an image.
  showPicture(stream, picture, bytes) {
    this.framesShown += 1;
    // The smaller stream of a moving camera counts as interactive, at its scale.
    const fullWidth = this.fullSize().width;
    const id = frameId(stream, picture.sequence);
    // (H.264's full size may be a pixel narrower: its sides are even.)
    this.frame = {id, width: picture.width, height: picture.height, sequence: picture.sequence,
                  interactive: picture.width < fullWidth - 1 ? picture.width / fullWidth : 0};
    this.perf.shown(this.frame);
    this.onFrame({id, bytes, codec: `${this.codec} ${PLAYER_NAMES[this.player]}`});
    const text = `${picture.width}\u00d7${picture.height} ${this.codec.toUpperCase()} via ` +
                 `${PLAYER_NAMES[this.player]}${this.interactive ? ' (moving)' : ''}`;
    if (this.status.textContent !== text) this.status.textContent = text;
    this.noteShown();
  }

  // A picture of animated lights (its chunk's animation time is above 0): once they have been
  // shown for ANIMATION_WINDOW_MS without input, the rate they were shown at is judged, once a
  // second (adaptive.js: video that cannot keep up gives way to the JPEG stream).
  checkAnimation(chunk) {
    const now = performance.now();
    if (!(chunk.time > 0)) {
      this.animatingSince = 0;
      return;
    }
    if (!this.animatingSince) this.animatingSince = now;
    const since = Math.max(this.animatingSince, this.lastInputAt);
    if (this.interactive || now - since < ANIMATION_WINDOW_MS || now - this.animationCheckedAt < 1000) return;
    this.animationCheckedAt = now;
    const why = this.learnt.animated(this.mode, this.perf.fps(ANIMATION_WINDOW_MS));
    if (why && this.useJpeg(why)) this.onPathChange(why);
  }

  noteShown() {
    this.retryDelayMs = FIRST_RETRY_MS;
    if (this.troubled) {
      this.troubled = false;
      this.onRecovered();
    }
  }

  // A part arrived: to the <img> (image.js), as the stream's frame `frameId`.
  show(stream, part) {
    this.framesShown += 1;
    const id = frameId(stream, part.headers['x-myriad-frame'] || '');
    this.onFrame({id, bytes: part.body.byteLength, codec: this.codec});
    this.noteShown();
    this.images.show(stream, part, id, () => this.stream === stream);
  }

  // A part shows in the <img> (its figures from the stream's metadata).
  imageShown(figures) {
    this.frame = figures;
    this.perf.shown(figures);
    // Written only when it changes: each write is a style, layout and paint pass of the page.
    const text = `${figures.width}\u00d7${figures.height} JPEG${figures.interactive ? ' (moving)' : ''}`;
    if (this.status.textContent !== text) this.status.textContent = text;
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

// A frame's name for the overlay and perf.js: the stream it came in (its serial: every stream
// opened is a new one, even at the same address) and its X-Myriad-Frame sequence (a re-send
// keeps it).
function frameId(stream, sequence) {
  return `${stream.serial}:${stream.key}#${sequence}`;
}
