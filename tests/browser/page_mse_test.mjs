// The page's Media Source Extensions player (client/web/mse.js, issue 35) in Debian's Chromium
// (headless, playwright-core) against the real server with validation: the page opened with
// ?stream=mse (VP9 in live WebM) and with ?stream=h264 (H.264 in fragmented MP4) plays its
// session's stream in a <video id="video">, says so (#view's data-player, the status line), and:
// - a still scene: the one picture the stream sends is shown at the size asked for
//   (videoWidth x videoHeight = the stream's width and height), and drawn on a canvas it is lit
//   and within MAX_MEAN_DIFFERENCE (mean absolute difference per channel, 0..255) of the PNG of
//   GET .../frame of the same state at the same size;
// - the lights animating: currentTime advances, getVideoPlaybackQuality().totalVideoFrames
//   grows by at least MIN_FRAMES in PLAY_S seconds and as many pictures are presented
//   (requestVideoFrameCallback, perf.js), the playhead stays within MAX_LAG_S of the newest
//   buffered time, and what was played is removed (buffered starts after 0 and spans at most
//   MAX_BUFFERED_S once the stream has a second key frame: a second stream of the channel,
//   opened by the test for a moment, has the shared encoder make one);
//   Measured here (lavapipe rendering 12-20 frames a second at 400x300): 12-16 pictures a
//   second presented, the playhead behind the newest buffered time by a median 0.15-0.20 s
//   (VP9; Chromium's estimated 63 ms duration of a WebM block is part of it) and 0.05-0.07 s
//   (H.264), at most 0.32 s. Chromium's droppedVideoFrames counts most H.264 frames as dropped
//   while requestVideoFrameCallback reports them presented: it is printed, not checked.
// - a resized view gets a new stream whose <video> takes the old one's place (one left);
// - the session deleted, no <video> stays.
// Then the page without WebCodecs (VideoDecoder deleted) chooses Media Source Extensions by
// itself and says why, and without MediaSource too, the JPEG stream. And the page's key frame
// reader (KeyFrameTimes) finds the same key frames in a real stream fed whole and in 1-7 byte
// pieces. A codec this Chromium cannot play (MediaSource.isTypeSupported) is skipped with its
// reason printed; Debian 12's Chromium 156 plays both.
//
// Usage: node page_mse_test.mjs <path to myriad-server>. Exit 0 pass, 1 fail, 77 skip (no
// Chromium at /usr/bin/chromium).

import {existsSync} from 'node:fs';
import {check, until} from './helpers.mjs';
import {startServer} from './server_process.mjs';

const CHROMIUM = '/usr/bin/chromium';
// The view is the window less the 340 px panel: a 400x300 stream.
const VIEWPORT = {width: 740, height: 300};
// Measured here (lavapipe, 400x300 key frame at the default bitrate; the same in every run): VP9
// 3.68, H.264 1.77. The bound leaves room for another renderer's picture (harder or easier to
// encode) and another Chromium's colour conversion, far below a blank picture (a black one is
// 31.9 away here: printed as "a black picture's").
const MAX_MEAN_DIFFERENCE = 10;
const PLAY_S = 14;
const MIN_FRAMES = 30;
const MAX_LAG_S = 0.6;
const MAX_BUFFERED_S = 16;

if (!existsSync(CHROMIUM)) {
  console.log(`SKIP: ${CHROMIUM} is absent (scripts/install-deps.sh --with-test-tools installs it).`);
  process.exit(77);
}
const {chromium} = await import('playwright-core');
const serverPath = process.argv[2];
if (!serverPath) {
  console.error('usage: node page_mse_test.mjs <myriad-server>');
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

// In the page: what the <video id="video"> shows and how it plays.
function videoInPage() {
  const video = document.getElementById('video');
  const view = document.getElementById('view');
  const out = {tag: video?.tagName || '', player: view.dataset.player || '', codec: view.dataset.codec || '',
               why: view.dataset.codecWhy || '', status: document.getElementById('view-status').textContent,
               videos: view.querySelectorAll('video').length};
  if (!(video instanceof HTMLVideoElement)) return out;
  const quality = video.getVideoPlaybackQuality();
  const ranges = [];
  for (let i = 0; i < video.buffered.length; ++i) ranges.push([video.buffered.start(i), video.buffered.end(i)]);
  return {...out, shown: video.dataset.shown || '', width: video.videoWidth, height: video.videoHeight,
          time: video.currentTime, frames: quality.totalVideoFrames, dropped: quality.droppedVideoFrames,
          ranges, paused: video.paused, error: video.error?.message || '', now: performance.now()};
}

// In the page: the <video>'s picture drawn on a canvas against the PNG of GET .../frame at its
// size: {lit (share of pixels brighter than near black), mean (absolute difference a channel),
// black (what a black picture's mean would be: the PNG's mean)}.
async function compareInPage({path, token}) {
  const video = document.getElementById('video');
  const width = video.videoWidth;
  const height = video.videoHeight;
  const pixels = (source) => {
    const canvas = document.createElement('canvas');
    canvas.width = width;
    canvas.height = height;
    const context = canvas.getContext('2d', {willReadFrequently: true});
    context.drawImage(source, 0, 0, width, height);
    return context.getImageData(0, 0, width, height).data;
  };
  const shown = pixels(video);
  const res = await fetch(`${path}/frame?format=png&width=${width}&height=${height}`,
                          {headers: {Authorization: `Bearer ${token}`}});
  const png = pixels(await createImageBitmap(await res.blob()));
  let sum = 0;
  let black = 0;
  let lit = 0;
  for (let i = 0; i < shown.length; i += 4) {
    for (let c = 0; c < 3; ++c) {
      sum += Math.abs(shown[i + c] - png[i + c]);
      black += png[i + c];
    }
    if (shown[i] + shown[i + 1] + shown[i + 2] > 60) ++lit;
  }
  const n = width * height * 3;
  return {lit: lit / (width * height), mean: sum / n, black: black / n};
}

const browser = await chromium.launch({executablePath: CHROMIUM,
                                       args: ['--headless', '--no-sandbox', '--disable-gpu']});
const consoleErrors = [];
// A page of its own (its own localStorage: its own session), with `init` run before its scripts.
async function openPage(query, init = null) {
  const context = await browser.newContext({viewport: VIEWPORT});
  const page = await context.newPage();
  page.on('console', (msg) => {
    // The session deleted on purpose: its stream's reopening is refused (404).
    if (msg.type() === 'error' && !/status of 404/.test(msg.text())) {
      consoleErrors.push(`${query}: ${msg.text()} (${msg.location().url})`);
    }
  });
  page.on('pageerror', (e) => consoleErrors.push(`${query}: uncaught ${e.message}`));
  if (init) await page.addInitScript(init);
  await page.goto(`${base}/${query}`);
  return page;
}

try {
  const supported = await (async () => {
    const page = await openPage('?stream=jpeg');
    const answer = await page.evaluate(() => ({
      vp9: MediaSource.isTypeSupported('video/webm; codecs="vp09.00.10.08"'),
      h264: MediaSource.isTypeSupported('video/mp4; codecs="avc1.42C01F"'),
    }));
    await page.context().close();
    return answer;
  })();
  console.log(`     MediaSource.isTypeSupported: VP9 in WebM ${supported.vp9}, H.264 in MP4 ${supported.h264}`);

  for (const [name, query, codec, container] of [['VP9 in WebM', '?stream=mse', 'vp9', 'webm'],
                                                 ['H.264 in MP4', '?stream=h264', 'h264', 'mp4']]) {
    await step(`${name}: the page plays its stream through Media Source Extensions`, async () => {
      if (!supported[codec]) {
        console.log(`     SKIP ${name}: MediaSource.isTypeSupported says this Chromium cannot play it`);
        return;
      }
      const page = await openPage(query);
      let session = null;
      try {
        const first = await until('a picture in the <video>', async () => {
          const s = await page.evaluate(videoInPage);
          if (s.error) throw new Error(s.error);
          return s.tag === 'VIDEO' && s.shown && s.width > 0 ? s : null;
        });
        session = await page.evaluate(() => JSON.parse(localStorage.getItem('myriad.session')));
        const path = `/v1/sessions/${session.id}`;
        const asked = new URL(first.shown, base).searchParams;
        console.log(`     ${name}: ${first.shown}; status "${first.status}"; why "${first.why}"`);
        check(first.player === 'mse' && first.codec === codec, `data-player ${first.player}, data-codec ${first.codec}`);
        check(asked.get('codec') === codec && asked.get('container') === container, `the stream ${first.shown}`);
        check(first.width === Number(asked.get('width')) && first.height === Number(asked.get('height')),
              `the video is ${first.width}x${first.height}, the stream asked for ` +
              `${asked.get('width')}x${asked.get('height')}`);
        check(first.width >= VIEWPORT.width - 340 - 1 && first.height === VIEWPORT.height,
              `the stream ${first.width}x${first.height} is not the view's size`);
        check(new RegExp(`${codec.toUpperCase()} via MSE`).test(first.status), `the status line: "${first.status}"`);

        // The still scene's one picture against the PNG of the same state (no frame since 1 s).
        let last = first;
        const still = await until('the still picture', async () => {
          await new Promise((r) => setTimeout(r, 1000));
          const s = await page.evaluate(videoInPage);
          const same = s.frames === last.frames;
          last = s;
          return same ? s : null;
        }, 30000, 0);
        const compared = await page.evaluate(compareInPage, {path, token: session.token});
        console.log(`     ${name}: still picture ${still.width}x${still.height}, ${still.frames} frame(s): ` +
                    `${(compared.lit * 100).toFixed(1)}% lit, mean absolute difference from the PNG ` +
                    `${compared.mean.toFixed(2)} (bound ${MAX_MEAN_DIFFERENCE}; a black picture's ${compared.black.toFixed(1)})`);
        check(compared.lit > 0.1, `only ${(compared.lit * 100).toFixed(1)}% of the picture is lit`);
        check(compared.mean < MAX_MEAN_DIFFERENCE,
              `the picture differs from the PNG by ${compared.mean.toFixed(2)} on average`);

        // Playing: the lights animate.
        check((await api('PATCH', `${path}/settings`, {token: session.token, json: {animate: true}})).status === 200,
              'PATCH settings animate');
        const moving = await until('frames of the animation', async () => {
          const s = await page.evaluate(videoInPage);
          return s.frames >= still.frames + 5 ? s : null;
        });
        // Sampled every 500 ms for PLAY_S, and on until played media was removed. Removal ends
        // at a key frame, and the encoder's own come every 300 frames (10 s at 30 fps; more on a
        // renderer slower than that): a second stream of the same channel, opened here for a
        // moment, gets the shared encoder to make one now (protocol/reference.md).
        const lags = [];
        const samples = [];
        const playStart = performance.now();
        let joined = false;
        const removed = (s) => s.ranges.length === 1 && s.ranges[0][0] > 0;
        await until('played media to be removed', async () => {
          await new Promise((r) => setTimeout(r, 500));
          const s = await page.evaluate(videoInPage);
          if (s.error) throw new Error(s.error);
          samples.push(s);
          if (s.ranges.length) lags.push(s.ranges.at(-1)[1] - s.time);
          if (!joined && s.time > 3) {
            joined = true;
            const joiner = new URL(s.shown, base);
            joiner.searchParams.set('container', codec === 'h264' ? 'mp4' : 'myriad');
            const abort = new AbortController();
            const res = await fetch(joiner, {headers: {Authorization: `Bearer ${session.token}`}, signal: abort.signal});
            await res.body.getReader().read();  // its first chunk: the key frame
            abort.abort();
          }
          return performance.now() - playStart >= PLAY_S * 1000 && removed(s) ? s : null;
        }, 60000, 0);
        const end = samples.at(-1);
        const playing = samples.filter((s, i) => i < PLAY_S * 2);
        const span = end.ranges.at(-1)[1] - end.ranges[0][0];
        lags.sort((a, b) => a - b);
        const played = playing.at(-1);
        // The pictures the page was told were presented (requestVideoFrameCallback, perf.js).
        const presented = await page.evaluate(([from, to]) =>
            window.myriadPerf.frames.filter((f) => f.t > from && f.t <= to).length, [moving.now, played.now]);
        const seconds = (played.now - moving.now) / 1000;
        console.log(`     ${name}: in ${PLAY_S} s currentTime ${moving.time.toFixed(2)} -> ${played.time.toFixed(2)} s, ` +
                    `frames ${moving.frames} -> ${played.frames} (${played.dropped} counted dropped, ` +
                    `${presented} presented: ${(presented / seconds).toFixed(1)} a second); behind the live edge ` +
                    `median ${lags[lags.length >> 1].toFixed(3)} s, most ${lags.at(-1).toFixed(3)} s ` +
                    `(${lags.length} samples); after ${((performance.now() - playStart) / 1000).toFixed(1)} s ` +
                    `buffered ${end.ranges.map(([a, b]) => `${a.toFixed(2)}-${b.toFixed(2)}`).join(', ')} ` +
                    `at ${end.time.toFixed(2)} s`);
        check(played.time - moving.time > PLAY_S / 4, `currentTime went ${moving.time} -> ${played.time}`);
        check(played.frames - moving.frames >= MIN_FRAMES, `only ${played.frames - moving.frames} frames in ${PLAY_S} s`);
        check(presented >= MIN_FRAMES, `only ${presented} pictures presented in ${PLAY_S} s`);
        check(lags.at(-1) < MAX_LAG_S, `the playhead was up to ${lags.at(-1).toFixed(2)} s behind the live edge`);
        check(span <= MAX_BUFFERED_S, `buffered spans ${span.toFixed(2)} s`);
        check(samples.every((s) => s.videos === 1), 'more than one <video> while one stream plays');

        // A new size is a new stream: its <video> replaces the old one.
        await page.setViewportSize({width: VIEWPORT.width - 100, height: VIEWPORT.height});
        const resized = await until('the resized stream', async () => {
          const s = await page.evaluate(videoInPage);
          return s.tag === 'VIDEO' && s.width === VIEWPORT.width - 440 && s.videos === 1 ? s : null;
        });
        console.log(`     ${name}: resized: ${resized.width}x${resized.height}, ${resized.videos} <video>`);

        // The session deleted: the page says so and no <video> stays.
        check((await api('DELETE', path, {token: session.token})).status === 204, 'DELETE the session');
        session = null;
        await until('the <video> to go', async () => {
          const s = await page.evaluate(videoInPage);
          return s.videos === 0 && await page.isVisible('#message') ? s : null;
        });
      } finally {
        await page.context().close();
        if (session) await api('DELETE', `/v1/sessions/${session.id}`, {token: session.token});
      }
    });
  }

  await step('without WebCodecs the page chooses MSE and says why; without MediaSource too, JPEG', async () => {
    const page = await openPage('', () => { delete globalThis.VideoDecoder; });
    const s = await until('a picture in the <video>', async () => {
      const now = await page.evaluate(videoInPage);
      return now.tag === 'VIDEO' && now.shown && now.width > 0 ? now : null;
    });
    check(s.player === 'mse' && s.codec === 'vp9', `data-player ${s.player}, data-codec ${s.codec}`);
    check(/WebCodecs is unavailable/.test(s.why), `why: "${s.why}"`);
    check(/VP9 via MSE/.test(s.status), `the status line: "${s.status}"`);
    const session = await page.evaluate(() => JSON.parse(localStorage.getItem('myriad.session')));
    await page.context().close();
    await api('DELETE', `/v1/sessions/${session.id}`, {token: session.token});

    const bare = await openPage('', () => {
      delete globalThis.VideoDecoder;
      delete globalThis.MediaSource;
    });
    const j = await until('a JPEG picture', async () => {
      const now = await bare.evaluate(videoInPage);
      return now.player === 'jpeg' && / JPEG/.test(now.status) ? now : null;
    });
    check(/WebCodecs is unavailable/.test(j.why) && /Media Source Extensions are unavailable/.test(j.why),
          `why: "${j.why}"`);
    check(j.videos === 0 && j.tag === '', 'a video element without video');
    const bareSession = await bare.evaluate(() => JSON.parse(localStorage.getItem('myriad.session')));
    await bare.context().close();
    await api('DELETE', `/v1/sessions/${bareSession.id}`, {token: bareSession.token});
  });

  await step('KeyFrameTimes: the key frames of a real stream, fed whole and in 1-7 byte pieces', async () => {
    const created = (await api('POST', '/v1/sessions', {json: {}})).body;
    const path = `/v1/sessions/${created.id}`;
    await api('PATCH', `${path}/settings`, {token: created.token, json: {animate: true}});
    const page = await openPage('?stream=jpeg');
    try {
      for (const [codec, container] of [['vp9', 'webm'], ['h264', 'mp4']]) {
        // A 160x96 stream up to its second key frame (forced by a second stream after 2 s).
        const found = await page.evaluate(async ({path, token, codec, container}) => {
          const {KeyFrameTimes} = await import('/web/mse.js');
          const abort = new AbortController();
          const res = await fetch(`${path}/stream?codec=${codec}&container=${container}&width=160&height=96&fps=10`,
                                  {headers: {Authorization: `Bearer ${token}`}, signal: abort.signal});
          const reader = res.body.getReader();
          const pieces = [];
          const whole = new KeyFrameTimes(container);
          const start = performance.now();
          let joined = false;
          while (performance.now() < start + 20000 && whole.times.length < 2) {
            const {value, done} = await reader.read();
            if (done) break;
            pieces.push(value);
            whole.feed(value);
            if (!joined && performance.now() > start + 2000) {
              // A second stream of the channel: the shared encoder makes a key frame for it.
              joined = true;
              const second = new AbortController();
              const mine = await fetch(`${path}/stream?codec=${codec}&width=160&height=96&fps=10`,
                                       {headers: {Authorization: `Bearer ${token}`}, signal: second.signal});
              await mine.body.getReader().read();
              second.abort();
            }
          }
          abort.abort();
          const all = new Uint8Array(pieces.reduce((n, p) => n + p.length, 0));
          let at = 0;
          for (const p of pieces) {
            all.set(p, at);
            at += p.length;
          }
          const split = new KeyFrameTimes(container);
          for (let i = 0, n = 1; i < all.length; i += n, n = n % 7 + 1) split.feed(all.slice(i, i + n));
          return {whole: whole.times, split: split.times, bytes: all.length};
        }, {path, token: created.token, codec, container});
        console.log(`     ${codec} in ${container}: ${found.bytes} bytes, key frames at ${found.whole.join(', ')} s`);
        check(found.whole.length === 2 && found.whole[0] === 0 && found.whole[1] > 0.5,
              `${codec}: key frames at ${found.whole.join(', ')}`);
        check(JSON.stringify(found.split) === JSON.stringify(found.whole),
              `${codec}: in pieces ${found.split.join(', ')}`);
      }
    } finally {
      await page.context().close();
      await api('DELETE', path, {token: created.token});
    }
  });

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

console.log(`page MSE test: ${Math.round(performance.now() - started)} ms`);
if (failures.length) {
  console.log(`\n${failures.length} failed:\n${failures.join('\n')}`);
  process.exit(1);
}
console.log('all passed');
