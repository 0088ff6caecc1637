// client/web/video.js's VideoChunkReader on hand-made chunks (the layout of protocol/reference.md
// "Video streams"), fed whole and split at every byte: header members, payloads, keep-alives, and
// the errors a broken stream gives.
// Usage: node video_chunks_test.mjs. Exit 0 pass, 1 fail.

import {HEADER_BYTES, KIND_DELTA, KIND_KEEP_ALIVE, KIND_KEY, VideoChunkReader} from '../../client/web/video.js';

let failures = 0;
function check(condition, message) {
  if (!condition) {
    ++failures;
    console.log(`FAIL ${message}`);
  }
}

function chunk({kind, width = 320, height = 180, sequence, timestampUs, version, time, encodeUs, payload}) {
  const bytes = new Uint8Array(HEADER_BYTES + payload.length);
  const view = new DataView(bytes.buffer);
  view.setUint32(0, payload.length, true);
  view.setUint8(4, kind);
  view.setUint16(8, width, true);
  view.setUint16(10, height, true);
  view.setUint32(12, sequence, true);
  view.setBigUint64(16, BigInt(timestampUs), true);
  view.setBigUint64(24, BigInt(version), true);
  view.setFloat64(32, time, true);
  view.setUint32(40, encodeUs, true);
  bytes.set(payload, HEADER_BYTES);
  return bytes;
}

const first = {kind: KIND_KEY, sequence: 1, timestampUs: 0, version: 7, time: 1.25, encodeUs: 4100,
               payload: Uint8Array.from({length: 300}, (_, i) => i & 255)};
const idle = {kind: KIND_KEEP_ALIVE, sequence: 1, timestampUs: 2000000, version: 7, time: 1.25,
              encodeUs: 0, payload: new Uint8Array(0)};
const second = {kind: KIND_DELTA, width: 322, sequence: 2, timestampUs: 2100333, version: 9,
                time: 3.5, encodeUs: 900, payload: Uint8Array.from([9, 8, 7])};
const stream = new Uint8Array([...chunk(first), ...chunk(idle), ...chunk(second)]);

function same(got, want, what) {
  check(got.kind === want.kind, `${what}: kind ${got.kind}`);
  check(got.width === (want.width ?? 320) && got.height === 180, `${what}: size ${got.width}x${got.height}`);
  for (const key of ['sequence', 'timestampUs', 'version', 'time', 'encodeUs']) {
    check(got[key] === want[key], `${what}: ${key} ${got[key]} != ${want[key]}`);
  }
  check(got.payload.length === want.payload.length &&
        got.payload.every((b, i) => b === want.payload[i]), `${what}: payload`);
}

// Whole, then split at every byte offset (two pieces), then one byte at a time.
for (const cuts of [[], ...Array.from({length: stream.length - 1}, (_, i) => [i + 1]), 'bytes']) {
  const reader = new VideoChunkReader();
  const got = [];
  const pieces = cuts === 'bytes' ? Array.from(stream, (_, i) => [i, i + 1])
                                  : [[0, cuts[0] ?? stream.length], [cuts[0] ?? stream.length, stream.length]];
  for (const [from, to] of pieces) got.push(...reader.feed(stream.subarray(from, to)));
  const what = cuts === 'bytes' ? 'byte by byte' : `cut at ${cuts[0] ?? 'nothing'}`;
  check(got.length === 3, `${what}: ${got.length} chunks`);
  if (got.length === 3) {
    same(got[0], first, `${what}, key`);
    same(got[1], idle, `${what}, keep-alive`);
    same(got[2], second, `${what}, delta`);
  }
  check(reader.bytes === stream.length, `${what}: ${reader.bytes} bytes counted`);
}

// A partial chunk gives nothing yet.
check(new VideoChunkReader().feed(chunk(first).subarray(0, HEADER_BYTES + 10)).length === 0,
      'a partial chunk');

// Broken streams: an unknown kind, an absurd length.
const bad = chunk({...first, kind: 9});
let threw = '';
try { new VideoChunkReader().feed(bad); } catch (e) { threw = e.message; }
check(threw.includes('unknown kind 9'), `unknown kind: "${threw}"`);
const huge = chunk(first);
new DataView(huge.buffer).setUint32(0, 0xffffffff, true);
threw = '';
try { new VideoChunkReader().feed(huge); } catch (e) { threw = e.message; }
check(threw.includes('4294967295 bytes'), `absurd length: "${threw}"`);

console.log(failures ? `${failures} failed` : 'video chunk reader: all passed');
process.exit(failures ? 1 : 0);
