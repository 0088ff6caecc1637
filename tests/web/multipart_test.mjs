// client/web/multipart.js on hand-made input, fed whole and split at every byte: the parts, their
// headers and bodies, the end of the body, and the errors a malformed stream gives.
// Usage: node multipart_test.mjs. Exit 0 pass, 1 fail.

import {MultipartReader, multipartBoundary} from '../../client/web/multipart.js';

let failures = 0;
function check(condition, message) {
  if (!condition) {
    ++failures;
    console.log(`FAIL ${message}`);
  }
}

const bytes = (text) => new TextEncoder().encode(text);
const text = (body) => new TextDecoder().decode(body);

// Feeds `input` in pieces cut at `cuts` (byte offsets) and returns every part that came out.
function readAll(input, cuts, boundary = 'myriad-frame') {
  const reader = new MultipartReader(boundary);
  const parts = [];
  let at = 0;
  for (const cut of [...cuts, input.length]) {
    parts.push(...reader.feed(input.subarray(at, cut)));
    at = cut;
  }
  return {parts, finished: reader.finished};
}

check(multipartBoundary('multipart/x-mixed-replace; boundary=myriad-frame') === 'myriad-frame',
      'boundary parameter');
check(multipartBoundary('multipart/x-mixed-replace;boundary="a b"') === 'a b', 'quoted boundary');
check(multipartBoundary('image/jpeg') === null, 'no boundary');

// Myriad's framing: Content-Length parts, the boundary line written after each image. The second
// body contains CR LF and a line that starts like the boundary: Content-Length must win.
const trap = '\r\n--myriad-frame\r\n';
const server = bytes(
    '--myriad-frame\r\nContent-Type: image/jpeg\r\nContent-Length: 4\r\nX-Myriad-Frame: 1\r\n\r\n' +
    'JPEG\r\n--myriad-frame\r\n' +
    `Content-Type: image/jpeg\r\nContent-Length: ${trap.length + 2}\r\nX-Myriad-Frame: 2\r\n\r\n` +
    `AB${trap}\r\n--myriad-frame\r\n`);
for (let cut = 0; cut <= server.length; ++cut) {
  const {parts} = readAll(server, cut === 0 ? [] : [cut]);
  const ok = parts.length === 2 && text(parts[0].body) === 'JPEG' &&
             parts[0].headers['x-myriad-frame'] === '1' &&
             parts[0].headers['content-type'] === 'image/jpeg' &&
             text(parts[1].body) === `AB${trap}` && parts[1].headers['x-myriad-frame'] === '2';
  check(ok, `Myriad framing split at byte ${cut}: ${JSON.stringify(parts.map((p) => text(p.body)))}`);
}
// Byte by byte: each part comes out with the byte that completes it, not later.
{
  const reader = new MultipartReader('myriad-frame');
  const firstEnd = server.indexOf(bytes('JPEG')[3]) + 1;  // the last byte of the first body
  let firstAt = -1;
  for (let i = 0; i < server.length; ++i) {
    if (reader.feed(server.subarray(i, i + 1)).length && firstAt < 0) firstAt = i + 1;
  }
  check(firstAt === firstEnd, `the first part came out after byte ${firstAt}, its body ends at ${firstEnd}`);
}

// Parts without Content-Length end at the next boundary; the closing boundary ends the body.
const plain = bytes('preamble\r\n--b\r\nContent-Type: text/plain\r\n\r\none\r\n--b\r\n\r\ntwo\r\n--b--\r\nepilogue');
for (let cut = 0; cut <= plain.length; ++cut) {
  const {parts, finished} = readAll(plain, cut === 0 ? [] : [cut], 'b');
  check(parts.length === 2 && text(parts[0].body) === 'one' && text(parts[1].body) === 'two' && finished,
        `boundary-delimited split at byte ${cut}: ${JSON.stringify(parts.map((p) => text(p.body)))}, finished ${finished}`);
}

// Malformed input is an error, not a wrong part.
const throws = (input, what) => {
  try {
    new MultipartReader('b').feed(bytes(input));
    check(false, `${what}: no error`);
  } catch (e) {
    check(e instanceof Error && e.message.length > 0, `${what}: ${e}`);
  }
};
throws('--b\r\nno colon here\r\n\r\nx', 'a header line without a colon');
throws('--b\r\nContent-Length: 12x\r\n\r\nx', 'a bad Content-Length');
throws('x'.repeat(70000), 'no boundary in 70000 bytes');

console.log(failures ? `${failures} failed` : 'all passed');
process.exit(failures ? 1 : 0);
