// client/web/multipart.js on random input, the JavaScript side of tests/fuzz (libFuzzer covers
// the CLI's C++ reader). Streams made from Myriad's framing by random mutations (bytes flipped,
// inserted, deleted, cut, sections repeated) are read whole, byte by byte and in random pieces:
// the three must give the same parts, or all fail with an Error (never another exception type, a
// hang or a part whose body is not its Content-Length long). Deterministic (seeded PRNG), so a
// failure prints a reproducible case number.
// Usage: node web_multipart_random.mjs [CASES]. Exit 0 pass, 1 fail.

import {MultipartReader} from '../../client/web/multipart.js';

const cases = Number(process.argv[2] || 3000);
let state = 0x2545f491;
const random = (n) => {  // xorshift32: the same cases on every run
  state ^= state << 13; state >>>= 0;
  state ^= state >>> 17;
  state ^= state << 5; state >>>= 0;
  return state % n;
};
const bytes = (text) => new TextEncoder().encode(text);
const part = (body, seq, length = true) =>
  '--myriad-frame\r\nContent-Type: image/jpeg\r\n' +
  (length ? `Content-Length: ${body.length}\r\n` : '') + `X-Myriad-Frame: ${seq}\r\n\r\n${body}\r\n`;
const seeds = [
  part('first', 1) + part('\r\n--myriad-frame\r\nJPEG', 2) + part('third', 3),
  part('abc', 1, false) + part('def', 2, false) + '--myriad-frame--\r\n',
  'preamble\r\n' + part('x', 1) + '--myriad-frame--',
  '--myriad-frame\nContent-Length: 2\n\nok\n--myriad-frame--',
].map(bytes);
const pieces = [bytes('--myriad-frame'), bytes('\r\n'), bytes('Content-Length: '), bytes('9'), bytes(':')];

function mutate(input) {
  let out = Array.from(input);
  for (let n = 1 + random(4); n > 0; --n) {
    const at = random(out.length + 1);
    switch (random(5)) {
      case 0: if (out.length) out[at % out.length] = random(256); break;
      case 1: out.splice(at, 0, ...pieces[random(pieces.length)]); break;
      case 2: out.splice(at, 1 + random(8)); break;
      case 3: out = out.slice(0, at); break;
      case 4: out.splice(at, 0, ...out.slice(random(out.length + 1), random(out.length + 1))); break;
    }
  }
  return Uint8Array.from(out);
}

function read(input, sizes) {
  const reader = new MultipartReader('myriad-frame');
  const parts = [];
  try {
    for (let at = 0, i = 0; at < input.length; ++i) {
      const n = Math.max(1, sizes(i));
      parts.push(...reader.feed(input.subarray(at, at + n)));
      at += n;
    }
  } catch (e) {
    if (!(e instanceof Error) || !e.message) throw new Error(`threw a non-Error: ${e}`);
    return {failed: true};
  }
  return {failed: false, finished: reader.finished,
          parts: parts.map((p) => JSON.stringify([p.headers, Array.from(p.body)]))};
}

let failures = 0;
for (let c = 0; c < cases; ++c) {
  const input = mutate(seeds[random(seeds.length)]);
  const whole = read(input, () => input.length);
  const single = read(input, () => 1);
  const split = read(input, () => 1 + random(17));
  const same = (a, b) => a.failed === b.failed &&
      (a.failed || (a.finished === b.finished && JSON.stringify(a.parts) === JSON.stringify(b.parts)));
  if (!same(whole, single) || !same(whole, split)) {
    ++failures;
    console.log(`FAIL case ${c}: whole/byte-by-byte/split disagree on ${JSON.stringify(Array.from(input))}`);
  }
  for (const p of whole.parts || []) {
    const [headers, body] = JSON.parse(p);
    const length = headers['content-length'];
    if (length !== undefined && Number(length) !== body.length) {
      ++failures;
      console.log(`FAIL case ${c}: a body of ${body.length} bytes with Content-Length ${length}`);
    }
  }
}
console.log(failures ? `${failures} of ${cases} cases failed` : `all ${cases} random streams agree`);
process.exit(failures ? 1 : 0);
