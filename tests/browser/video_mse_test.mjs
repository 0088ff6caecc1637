// The standard-container streams (issue 35) played by a <video> element through Media Source
// Extensions in Debian's Chromium (headless, playwright-core), against the real server with
// validation: for GET .../stream?codec=vp9&container=webm (and ?codec=h264&container=mp4 where
// MediaSource.isTypeSupported says this Chromium plays H.264), a page of the server's origin
// fetches the stream with the session token, appends what arrives to a SourceBuffer made with
// the response's Content-Type and X-Myriad-Codec, and plays it muted: the decoded frames
// (getVideoPlaybackQuality().totalVideoFrames) must keep growing, the element must report the
// stream's size, and a canvas drawImage of the playing video must have lit (non-black) pixels.
// Then the scene stands still for 5 s (only keep-alives: a WebM Void element, an MP4 free box)
// and moves again: frames keep being decoded, and the playhead stays within 1 s of the live edge
// (with real-time timestamps MSE dropped the MP4 frames after the gap and played the WebM gap
// through, 5 s behind).
// No Myriad page code is involved: this is what any web player does with the stream.
//
// Usage: node video_mse_test.mjs <path to myriad-server>. Exit 0 pass, 1 fail, 77 skip (no
// Chromium at /usr/bin/chromium).

import {existsSync} from 'node:fs';
import {check, until} from './helpers.mjs';
import {startServer} from './server_process.mjs';

const CHROMIUM = '/usr/bin/chromium';
const WIDTH = 320, HEIGHT = 180, FPS = 15;

if (!existsSync(CHROMIUM)) {
  console.log(`SKIP: ${CHROMIUM} is absent (scripts/install-deps.sh --with-test-tools installs it).`);
  process.exit(77);
}
const {chromium} = await import('playwright-core');
const serverPath = process.argv[2];
if (!serverPath) {
  console.error('usage: node video_mse_test.mjs <myriad-server>');
  process.exit(2);
}

const failures = [];
const started = performance.now();
async function step(name, fn) {
  const start = performance.now();
  try {
    await fn();
    console.log(`ok   ${name} (${Math.round(performance.now() - start)} ms)`);
  } catch (e) {
    failures.push(`${name}: ${e.message}`);
    console.log(`FAIL ${name}: ${e.stack || e.message}`);
  }
}

const server = await startServer(serverPath, ['--validate', '--port', '0', '--lights', '8']);
const base = server.url;
console.log(`server at ${base}`);

async function api(method, path, {token, json} = {}) {
  const headers = {};
  if (token) headers.Authorization = `Bearer ${token}`;
  if (json !== undefined) headers['Content-Type'] = 'application/json';
  const res = await fetch(base + path, {method, headers, body: json === undefined ? undefined : JSON.stringify(json)});
  const text = await res.text();
  return {status: res.status, body: text.startsWith('{') ? JSON.parse(text) : text};
}

// In the page: plays `path` through MSE and records what the element did (window.mse).
function playInPage({path, token}) {
  const state = {error: null, type: null, codec: null, appended: 0, supported: null};
  window.mse = state;
  const video = document.createElement('video');
  video.muted = true;
  video.autoplay = true;
  document.body.append(video);
  state.video = video;
  (async () => {
    const res = await fetch(path, {headers: {Authorization: `Bearer ${token}`}});
    state.type = res.headers.get('Content-Type');
    state.codec = res.headers.get('X-Myriad-Codec');
    const mime = `${state.type}; codecs="${state.codec}"`;
    state.supported = MediaSource.isTypeSupported(mime);
    if (!state.supported) return;
    const source = new MediaSource();
    video.src = URL.createObjectURL(source);
    await new Promise((resolve) => source.addEventListener('sourceopen', resolve, {once: true}));
    const buffer = source.addSourceBuffer(mime);
    buffer.mode = 'segments';
    const reader = res.body.getReader();
    const queue = [];
    const pump = () => {
      if (buffer.updating || queue.length === 0) return;
      buffer.appendBuffer(queue.shift());
    };
    buffer.addEventListener('updateend', () => {
      // A live player's own logic: when the playhead is in no buffered range, jump to the newest.
      // (The server's timelines have no holes, even after a still scene: video_container.h.)
      const ranges = video.buffered;
      let inside = false;
      for (let i = 0; i < ranges.length; ++i) {
        if (video.currentTime >= ranges.start(i) && video.currentTime < ranges.end(i)) inside = true;
      }
      if (!inside && ranges.length && video.currentTime < ranges.start(ranges.length - 1)) {
        video.currentTime = ranges.start(ranges.length - 1);
      }
      pump();
    });
    buffer.addEventListener('error', () => { state.error = 'SourceBuffer error'; });
    video.addEventListener('error', () => { state.error = `video error ${video.error?.message}`; });
    video.play().catch((e) => { state.error = `play: ${e.message}`; });
    for (;;) {
      const {value, done} = await reader.read();
      if (done) break;
      state.appended += value.byteLength;
      queue.push(value);
      pump();
    }
  })().catch((e) => { state.error = e.message; });
}

// In the page: decoded frames so far, the element's size and the lit pixels of a canvas copy.
function sampleInPage() {
  const {video, error, appended, supported, type, codec} = window.mse;
  const out = {error, appended, supported, type, codec, frames: 0, width: video.videoWidth,
               height: video.videoHeight, lit: 0, time: video.currentTime};
  out.frames = video.getVideoPlaybackQuality().totalVideoFrames;
  out.buffered = [];
  for (let i = 0; i < video.buffered.length; ++i) {
    out.buffered.push(`${video.buffered.start(i).toFixed(2)}-${video.buffered.end(i).toFixed(2)}`);
  }
  if (video.videoWidth > 0) {
    const canvas = document.createElement('canvas');
    canvas.width = video.videoWidth;
    canvas.height = video.videoHeight;
    const context = canvas.getContext('2d');
    context.drawImage(video, 0, 0);
    const pixels = context.getImageData(0, 0, canvas.width, canvas.height).data;
    for (let i = 0; i < pixels.length; i += 4) {
      if (pixels[i] + pixels[i + 1] + pixels[i + 2] > 60) ++out.lit;
    }
  }
  return out;
}

const browser = await chromium.launch({executablePath: CHROMIUM,
                                       args: ['--headless', '--no-sandbox', '--disable-gpu',
                                              '--autoplay-policy=no-user-gesture-required']});
const consoleErrors = [];
try {
  const created = await api('POST', '/v1/sessions', {json: {}});
  const session = created.body;
  check(created.status === 201, `POST /v1/sessions -> ${created.status}`);
  const path = `/v1/sessions/${session.id}`;
  check((await api('PATCH', `${path}/settings`, {token: session.token, json: {animate: true}})).status === 200,
        'PATCH settings animate');

  for (const [name, query] of [['webm vp9', 'codec=vp9&container=webm'],
                               ['mp4 h264', 'codec=h264&container=mp4']]) {
    await step(`${name}: a <video> element plays the stream through MSE`, async () => {
      const page = await (await browser.newContext()).newPage();
      page.on('pageerror', (e) => consoleErrors.push(`${name}: uncaught ${e.message}`));
      // A page of the server's origin, so fetch needs no CORS.
      await page.goto(`${base}/v1/health`);
      const stream = `${path}/stream?${query}&width=${WIDTH}&height=${HEIGHT}&fps=${FPS}`;
      await page.evaluate(playInPage, {path: stream, token: session.token});
      const first = await until('the stream to start playing', async () => {
        const s = await page.evaluate(sampleInPage);
        if (s.error) throw new Error(s.error);
        if (s.supported === false) return s;
        return s.frames >= 3 && s.width > 0 ? s : null;
      }, 30000, 250);
      if (first.supported === false) {
        console.log(`     ${name}: this Chromium does not play ${first.type}; codecs="${first.codec}" (skipped)`);
        await page.context().close();
        return;
      }
      await new Promise((r) => setTimeout(r, 2000));
      const later = await page.evaluate(sampleInPage);
      console.log(`     ${name}: ${first.type}; codecs="${first.codec}": ${first.frames} -> ` +
                  `${later.frames} frames decoded in 2 s, ${later.width}x${later.height}, ` +
                  `${later.lit} lit pixels, ${later.appended} bytes, currentTime ${later.time.toFixed(2)} s`);
      check(!later.error, `${name}: ${later.error}`);
      check(later.frames > first.frames + 5, `${name}: only ${later.frames - first.frames} new frames in 2 s`);
      check(later.width === WIDTH && later.height === HEIGHT,
            `${name}: the video is ${later.width}x${later.height}, expected ${WIDTH}x${HEIGHT}`);
      check(later.lit > WIDTH * HEIGHT / 10, `${name}: only ${later.lit} lit pixels in the drawn frame`);
      // The scene stands still for 5 s (the stream sends only keep-alives: a WebM Void element,
      // an MP4 free box, every 2 s), then moves again: playback goes on, with no error.
      check((await api('PATCH', `${path}/settings`, {token: session.token, json: {animate: false}})).status === 200,
            'PATCH settings animate false');
      await new Promise((r) => setTimeout(r, 5000));
      const still = await page.evaluate(sampleInPage);
      check((await api('PATCH', `${path}/settings`, {token: session.token, json: {animate: true}})).status === 200,
            'PATCH settings animate true');
      const resumed = await until('frames after the still scene', async () => {
        const s = await page.evaluate(sampleInPage);
        if (s.error) throw new Error(s.error);
        return s.frames > still.frames + 5 ? s : null;
      }, 30000, 250).catch(async (e) => {
        const s = await page.evaluate(sampleInPage);
        throw new Error(`${e.message}: buffered ${s.buffered.join(', ')}, at ${s.time.toFixed(2)} s, ` +
                        `${s.frames} frames (${still.frames} when still), ${s.appended} bytes`);
      });
      console.log(`     ${name}: buffered ${still.buffered.join(', ')} at ${still.time.toFixed(2)} s`);
      await new Promise((r) => setTimeout(r, 2000));
      const end = await page.evaluate(sampleInPage);
      console.log(`     ${name}: still for 5 s (${still.appended - later.appended} bytes of ` +
                  `keep-alive and its last frame), then ${resumed.frames - still.frames} more ` +
                  `frames, ${end.frames - resumed.frames} in the next 2 s; buffered ` +
                  `${end.buffered.join(', ')} at ${end.time.toFixed(2)} s`);
      check(end.frames > resumed.frames + 5, `${name}: only ${end.frames - resumed.frames} frames ` +
                                             'in 2 s after the still scene');
      const liveEdge = end.buffered.length ? Number(end.buffered.at(-1).split('-')[1]) : 0;
      check(liveEdge - end.time < 1, `${name}: the playhead (${end.time.toFixed(2)} s) is ` +
                                     `${(liveEdge - end.time).toFixed(2)} s behind the live edge`);
      await page.context().close();
    });
  }

  await step('no page errors and no validation messages', async () => {
    check(consoleErrors.length === 0, consoleErrors.join('\n'));
    const info = await api('GET', '/v1/info');
    check(info.body.validation.messages === 0, `${info.body.validation.messages} validation messages`);
  });
} finally {
  await browser.close();
  const status = await server.stop();
  if (status !== 0) failures.push(`the server exited with ${status}:\n${server.log()}`);
}

console.log(`video MSE test: ${Math.round(performance.now() - started)} ms`);
if (failures.length) {
  console.log(`\n${failures.length} failed:\n${failures.join('\n')}`);
  process.exit(1);
}
console.log('all passed');
