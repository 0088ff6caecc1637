// Video streams (GET .../stream?codec=vp8|vp9, protocol/reference.md "Video streams"): the chunk
// framing, read as bytes arrive (pure: Node tests it on split input), and the player that decodes
// chunks with WebCodecs' VideoDecoder and draws each picture on a canvas.

export const HEADER_BYTES = 48;
export const KIND_KEY = 1;
export const KIND_DELTA = 2;
export const KIND_KEEP_ALIVE = 3;
const MAX_PAYLOAD = 64 * 1024 * 1024;  // far above any frame; a larger length is a broken stream

// Bytes in, whole chunks out: {kind, width, height, sequence, timestampUs, version, time,
// encodeUs, payload (Uint8Array)}. Throws on a chunk no server sends (unknown kind, absurd size).
export class VideoChunkReader {
  constructor() {
    this.buffer = new Uint8Array(0);
    this.bytes = 0;  // every byte fed so far
  }

  feed(bytes) {
    this.bytes += bytes.length;
    if (this.buffer.length === 0) {
      this.buffer = bytes;
    } else {
      const joined = new Uint8Array(this.buffer.length + bytes.length);
      joined.set(this.buffer);
      joined.set(bytes, this.buffer.length);
      this.buffer = joined;
    }
    const chunks = [];
    let at = 0;
    while (this.buffer.length - at >= HEADER_BYTES) {
      const view = new DataView(this.buffer.buffer, this.buffer.byteOffset + at, HEADER_BYTES);
      const size = view.getUint32(0, true);
      const kind = view.getUint8(4);
      if (kind < KIND_KEY || kind > KIND_KEEP_ALIVE) throw new Error(`video chunk of unknown kind ${kind}`);
      if (size > MAX_PAYLOAD) throw new Error(`video chunk of ${size} bytes`);
      if (this.buffer.length - at < HEADER_BYTES + size) break;
      chunks.push({
        kind,
        width: view.getUint16(8, true),
        height: view.getUint16(10, true),
        sequence: view.getUint32(12, true),
        timestampUs: Number(view.getBigUint64(16, true)),
        version: Number(view.getBigUint64(24, true)),
        time: view.getFloat64(32, true),
        encodeUs: view.getUint32(40, true),
        payload: this.buffer.slice(at + HEADER_BYTES, at + HEADER_BYTES + size),
      });
      at += HEADER_BYTES + size;
    }
    this.buffer = this.buffer.slice(at);
    return chunks;
  }
}

// Whether this page can decode `codec` (a WebCodecs codec string): {supported, why}. WebCodecs
// exists only in secure contexts (https, or http to localhost).
export async function videoSupport(codec) {
  if (!globalThis.isSecureContext || typeof globalThis.VideoDecoder === 'undefined') {
    return {supported: false, why: 'WebCodecs is unavailable here (it needs https or localhost)'};
  }
  try {
    const answer = await VideoDecoder.isConfigSupported({codec, optimizeForLatency: true});
    return answer.supported ? {supported: true, why: ''}
                            : {supported: false, why: `this browser cannot decode ${codec}`};
  } catch (e) {
    return {supported: false, why: `${codec}: ${e.message}`};
  }
}

// Decodes one stream's chunks and draws each picture on `canvas` as soon as it is decoded.
// onPicture(chunk) runs after each drawn picture (its chunk's header members); onError(error)
// when the decoder fails (the caller opens a new stream, which starts with a key frame).
export class VideoPlayer {
  constructor(canvas, codec, {onPicture = () => {}, onError = () => {}} = {}) {
    this.canvas = canvas;
    this.context = canvas.getContext('2d');
    this.pending = new Map();  // timestamp -> chunk, until its picture comes out
    this.decodeStarted = new Map();  // timestamp -> performance.now() when it went in
    this.decodeMs = 0;               // the last picture's decode time
    this.pictures = 0;
    this.waitingForKey = true;
    this.onPicture = onPicture;
    this.onError = onError;
    this.closed = false;
    this.decoder = new VideoDecoder({
      output: (frame) => this.draw(frame),
      error: (e) => {
        if (!this.closed) this.onError(e);
      },
    });
    this.decoder.configure({codec, optimizeForLatency: true});
  }

  push(chunk) {
    if (this.closed || chunk.kind === KIND_KEEP_ALIVE) return;
    if (this.waitingForKey) {
      if (chunk.kind !== KIND_KEY) return;  // a delta needs what came before it
      this.waitingForKey = false;
    }
    this.pending.set(chunk.timestampUs, chunk);
    this.decodeStarted.set(chunk.timestampUs, performance.now());
    this.decoder.decode(new EncodedVideoChunk({
      type: chunk.kind === KIND_KEY ? 'key' : 'delta',
      timestamp: chunk.timestampUs,
      data: chunk.payload,
    }));
  }

  draw(frame) {
    try {
      if (this.closed) return;
      const chunk = this.pending.get(frame.timestamp);
      this.pending.delete(frame.timestamp);
      const started = this.decodeStarted.get(frame.timestamp);
      this.decodeStarted.delete(frame.timestamp);
      if (started !== undefined) this.decodeMs = performance.now() - started;
      if (this.canvas.width !== frame.displayWidth) this.canvas.width = frame.displayWidth;
      if (this.canvas.height !== frame.displayHeight) this.canvas.height = frame.displayHeight;
      this.context.drawImage(frame, 0, 0);
      this.pictures += 1;
      if (chunk) this.onPicture(chunk);
    } finally {
      frame.close();
    }
  }

  close() {
    if (this.closed) return;
    this.closed = true;
    if (this.decoder.state !== 'closed') this.decoder.close();
    this.pending.clear();
    this.decodeStarted.clear();
  }
}
