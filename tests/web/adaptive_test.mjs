// client/web/adaptive.js in Node: the size of an encoded part from its own header, the stream size
// asked for a view (device pixels capped for a CPU renderer), and what the page learns from its
// drags (the JPEG stream's ?interactive=, the video interaction's scale, the switch to JPEG where
// video cannot hold the rate), kept per renderer.
// Usage: node adaptive_test.mjs. Exit 0 pass, 1 fail.

import {INTERACTIVE_FPS_STEPS, InteractiveRate, InteractiveScale, LearntInteraction, TARGET_FPS,
        dragRate, imageSize, streamSize} from '../../client/web/adaptive.js';

let failures = 0;
function check(condition, message) {
  if (!condition) {
    ++failures;
    console.log(`FAIL ${message}`);
  }
}

// --- imageSize ---------------------------------------------------------------------------------
// A JPEG's start: SOI, an APP0 segment, a DQT segment, then SOF0 with height 315, width 560.
const jpeg = Uint8Array.from([
  0xff, 0xd8,
  0xff, 0xe0, 0x00, 0x10, 0x4a, 0x46, 0x49, 0x46, 0x00, 0x01, 0x01, 0x00, 0x00, 0x01, 0x00, 0x01, 0x00, 0x00,
  0xff, 0xdb, 0x00, 0x04, 0x00, 0x01,
  0xff, 0xc0, 0x00, 0x11, 0x08, 0x01, 0x3b, 0x02, 0x30, 0x03, 0x01, 0x22, 0x00, 0x02, 0x11, 0x01, 0x03, 0x11, 0x01,
  0xff, 0xda, 0x00, 0x02]);
const size = imageSize(jpeg);
check(size && size.width === 560 && size.height === 315, `JPEG size ${JSON.stringify(size)}`);
// Progressive (SOF2) reads the same; DHT (C4) before it is skipped, not taken for a frame header.
const progressive = Uint8Array.from([0xff, 0xd8, 0xff, 0xc4, 0x00, 0x03, 0x00,
                                     0xff, 0xc2, 0x00, 0x0b, 0x08, 0x00, 0x5a, 0x00, 0xa0, 0x01, 0x01, 0x11, 0x00]);
const p2 = imageSize(progressive);
check(p2 && p2.width === 160 && p2.height === 90, `progressive JPEG size ${JSON.stringify(p2)}`);
// A PNG's IHDR: 1280 x 720.
const png = new Uint8Array(33);
png.set([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 13, 0x49, 0x48, 0x44, 0x52]);
new DataView(png.buffer).setUint32(16, 1280);
new DataView(png.buffer).setUint32(20, 720);
const p3 = imageSize(png);
check(p3 && p3.width === 1280 && p3.height === 720, `PNG size ${JSON.stringify(p3)}`);
check(imageSize(Uint8Array.from([1, 2, 3, 4, 5, 6, 7, 8, 9, 10])) === null, 'not an image: null');
check(imageSize(Uint8Array.from([0xff, 0xd8, 0xff, 0xda, 0, 2, 0, 0, 0, 0, 0, 0])) === null,
      'a scan before any frame header: null');

// --- streamSize --------------------------------------------------------------------------------
const phone = streamSize(390, 523, {ratio: 3, isCpu: true});
check(phone.width === 390 && phone.height === 523, `a 3x phone on a CPU renderer asks for ${JSON.stringify(phone)}`);
const phoneGpu = streamSize(390, 523, {ratio: 3, isCpu: false});
check(phoneGpu.width === 1170 && phoneGpu.height === 1569, `a 3x phone on a GPU asks for ${JSON.stringify(phoneGpu)}`);
const big = streamSize(2560, 1440, {ratio: 1, isCpu: true});
check(big.width * big.height <= 1280 * 800 && Math.abs(big.width / big.height - 16 / 9) < 0.01,
      `a 2560x1440 view on a CPU renderer asks for ${JSON.stringify(big)}`);
const wide = streamSize(3000, 1000, {ratio: 2, maxSide: 4096});
check(wide.width === 4096 && wide.height === 1365, `maxResolution caps the longer side: ${JSON.stringify(wide)}`);
const tiny = streamSize(4, 4, {minSide: 16});
check(tiny.width === 16 && tiny.height === 16, `at least minSide: ${JSON.stringify(tiny)}`);

// --- learning from drags -------------------------------------------------------------------------
// A drag of 3 s with 60 inputs a second, `fps` pictures a second after its first.
const drag = (fps, {ms = 3000, inputsPerS = 60} = {}) => {
  const frames = Math.round((fps * (ms - 200)) / 1000) + 1;
  return {ms, inputs: (inputsPerS * ms) / 1000, frames, spanMs: ((frames - 1) * 1000) / fps};
};
check(Math.abs(dragRate(drag(20)) - 20) < 1e-9, `dragRate ${dragRate(drag(20))}`);
check(Number.isNaN(dragRate({frames: 2, spanMs: 100})), 'too few pictures: no rate');

// JPEG: starts at 12; a miss asks the renderer for less (a higher N), a hold comes back down.
const rate = new InteractiveRate();
check(rate.fps === 12, `JPEG starts at interactive=${rate.fps}`);
check(!rate.learn(drag(30)) && rate.fps === 12, 'holding at the lowest N changes nothing');
check(rate.learn(drag(15)) && rate.fps === 14, `a miss at 12: ${rate.fps}`);
check(!rate.learn(drag(15, {inputsPerS: 10})) && rate.fps === 14, 'a slow drag says nothing');
check(rate.learn(drag(26)) === false && rate.fps === 14, 'a missed step is not tried again at once');
for (let i = 0; i < 8; ++i) rate.learn(drag(26));
check(rate.fps === 12, `after ${8} held drags the missed step is tried again: ${rate.fps}`);
check(INTERACTIVE_FPS_STEPS.every((n) => n >= 12 && n <= TARGET_FPS), 'N stays within 12..24');

// Video: from 1/2, a miss goes down by the square root of the rate's share, a hold up a step.
const scale = new InteractiveScale();
check(scale.scale === 0.5, `video starts at ${scale.scale}`);
scale.learn(drag(13.5));  // 0.5 * sqrt(13.5 / 24) = 0.375
check(scale.scale === 0.375, `a miss at 13.5 fps from 1/2: ${scale.scale}`);
scale.learn(drag(25));
check(scale.scale === 0.4375, `a hold goes up a step: ${scale.scale}`);
check(!scale.cannotHold, 'not at the smallest scale');

// LearntInteraction: video missing at 1/4 takes the JPEG path; kept per renderer.
const store = new Map();
const storage = {getItem: (k) => store.get(k) ?? null, setItem: (k, v) => store.set(k, v)};
const learnt = new LearntInteraction(storage);
learnt.restore('llvmpipe');
let outcome = {};
for (let i = 0; i < 6 && !outcome.jpeg; ++i) outcome = learnt.learn('video', drag(10));
check(learnt.scale.scale === 0.25 && /JPEG/.test(outcome.jpeg) && learnt.path === 'jpeg',
      `video missing at 1/4: ${learnt.scale.scale}, "${outcome.jpeg}"`);
const again = new LearntInteraction(storage);
again.restore('llvmpipe');
check(again.path === 'jpeg' && again.scale.scale === 0.25 && /video held 10\.0/.test(again.why),
      `restored on the same renderer: ${again.path} ${again.scale.scale} "${again.why}"`);
// At 1/4, a drag that does not hold 24 (though within 15% of it) is enough.
const close = new LearntInteraction(null);
close.scale = new InteractiveScale(0.25);
check(/video held 22\.0/.test(close.learn('video', drag(22)).jpeg || ''), 'video at 22 fps at 1/4 gives way');
const fine = new LearntInteraction(null);
fine.scale = new InteractiveScale(0.25);
check(!fine.learn('video', drag(25)).jpeg && fine.scale.scale === 0.3125, 'video holding 25 at 1/4 stays and grows');
const other = new LearntInteraction(storage);
other.restore('NVIDIA H200');
check(other.path === '' && other.scale.scale === 0.5 && other.rate.fps === 12,
      'another renderer starts afresh');
const held = new LearntInteraction(storage);
held.restore('NVIDIA H200');
for (let i = 0; i < 4; ++i) held.learn('video', drag(30));
check(held.path === '' && held.scale.scale === 0.75, `video holding the rate grows: ${held.scale.scale}`);

// Animated lights shown by video at less than the JPEG stream's animated rate: JPEG instead.
const anim = new LearntInteraction(null);
check(anim.animated('video', 11) === '' && anim.path === '', 'video at 11 fps of the animation keeps video');
check(/4\.0 frames a second of the animation/.test(anim.animated('video', 4)) && anim.path === 'jpeg',
      `video at 4 fps of the animation: "${anim.why}"`);
check(new LearntInteraction(null).animated('jpeg', 1) === '', 'the JPEG path is not judged');

if (failures) {
  console.log(`${failures} failed`);
  process.exit(1);
}
console.log('adaptive: all passed');
