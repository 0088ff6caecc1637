// Reads a multipart/x-mixed-replace body (GET .../stream) as it arrives: bytes in, whole parts
// out. Pure (no DOM, no network), so Node can test it on split input as well as the browser use it.
//
// A part ends after its Content-Length bytes when it has that header (Myriad's parts do), else
// just before the next boundary line. A part comes out as soon as its last byte is here: unlike an
// <img>, which shows a part only once the *next* part's headers arrive (Blink's multipart parser),
// so a still image would stay one part behind until the server's next re-send.

const CRLF_CRLF = [13, 10, 13, 10];
const MAX_GAP = 65536;  // bytes allowed between a part's end and the next boundary line

// The boundary parameter of a Content-Type ("multipart/x-mixed-replace; boundary=b" -> "b").
export function multipartBoundary(contentType) {
  const match = /;\s*boundary=("?)([^";]+)\1/i.exec(contentType || '');
  return match ? match[2] : null;
}

function indexOf(bytes, pattern, from) {
  const last = bytes.length - pattern.length;
  outer: for (let i = Math.max(0, from); i <= last; ++i) {
    for (let k = 0; k < pattern.length; ++k) {
      if (bytes[i + k] !== pattern[k]) continue outer;
    }
    return i;
  }
  return -1;
}

export class MultipartReader {
  constructor(boundary) {
    this.delimiter = new TextEncoder().encode(`--${boundary}`);
    this.buffer = new Uint8Array(0);
    this.state = 'boundary';   // 'boundary' | 'headers' | 'body' | 'done'
    this.headers = null;       // of the part being read; names in lower case
    this.length = -1;          // its Content-Length, or -1
  }

  get finished() {
    return this.state === 'done';
  }

  // Adds `chunk` (a Uint8Array); returns the parts it completed: [{headers, body}], body a
  // Uint8Array. Throws an Error on a malformed part (bad header line or Content-Length).
  feed(chunk) {
    const joined = new Uint8Array(this.buffer.length + chunk.length);
    joined.set(this.buffer);
    joined.set(chunk, this.buffer.length);
    this.buffer = joined;
    const parts = [];
    let at = 0;
    for (;;) {
      if (this.state === 'boundary') {
        const start = indexOf(this.buffer, this.delimiter, at);
        if (start < 0) {
          if (this.buffer.length - at > MAX_GAP) throw new Error('the stream has no boundary line');
          break;
        }
        const lineEnd = this.buffer.indexOf(10, start + this.delimiter.length);
        if (lineEnd < 0) break;
        const rest = this.buffer.subarray(start + this.delimiter.length, lineEnd);
        if (rest[0] === 45 && rest[1] === 45) {  // "--boundary--": the end of the body
          this.state = 'done';
          at = this.buffer.length;
          break;
        }
        at = lineEnd + 1;
        this.state = 'headers';
      } else if (this.state === 'headers') {
        if (this.buffer.length - at < 2) break;
        let bodyStart;
        if (this.buffer[at] === 13 && this.buffer[at + 1] === 10) {
          this.headers = {};  // a part without headers starts with the blank line
          bodyStart = at + 2;
        } else {
          const end = indexOf(this.buffer, CRLF_CRLF, at);
          if (end < 0) break;
          this.headers = parseHeaders(new TextDecoder().decode(this.buffer.subarray(at, end)));
          bodyStart = end + CRLF_CRLF.length;
        }
        const length = this.headers['content-length'];
        if (length !== undefined && !/^\d+$/.test(length)) {
          throw new Error(`a stream part has Content-Length "${length}"`);
        }
        this.length = length === undefined ? -1 : Number(length);
        at = bodyStart;
        this.state = 'body';
      } else if (this.state === 'body') {
        let bodyEnd;
        if (this.length >= 0) {
          if (this.buffer.length - at < this.length) break;
          bodyEnd = at + this.length;
        } else {
          const next = indexOf(this.buffer, this.delimiter, at);
          if (next < 0) break;
          bodyEnd = next;
          // The CRLF before a boundary belongs to the boundary.
          if (bodyEnd > at && this.buffer[bodyEnd - 1] === 10) --bodyEnd;
          if (bodyEnd > at && this.buffer[bodyEnd - 1] === 13) --bodyEnd;
        }
        parts.push({headers: this.headers, body: this.buffer.slice(at, bodyEnd)});
        at = bodyEnd;
        this.state = 'boundary';
      } else {
        at = this.buffer.length;  // after the closing boundary: ignored
        break;
      }
    }
    this.buffer = this.buffer.slice(at);
    return parts;
  }
}

function parseHeaders(text) {
  const headers = {};
  for (const line of text.split('\r\n')) {
    if (line === '') continue;
    const colon = line.indexOf(':');
    if (colon <= 0) throw new Error(`a stream part has the header line "${line.slice(0, 80)}"`);
    headers[line.slice(0, colon).trim().toLowerCase()] = line.slice(colon + 1).trim();
  }
  return headers;
}
