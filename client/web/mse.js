// Video streams in a standard container (GET .../stream?codec=...&container=webm|mp4,
// protocol/reference.md "Standard containers") played by a <video> element through Media Source
// Extensions: the page's path where WebCodecs is missing (an http page that is not localhost, a
// browser without VideoDecoder) but the browser's own player decodes the codec, and the only one
// for H.264 (the server sends it in MP4 only).
//
// The stream is read with fetch (the token in the Authorization header, as for every stream of
// the page) and each piece that arrives is appended to one SourceBuffer, in order: a SourceBuffer
// takes one append at a time, so pieces that come while it is busy wait in a queue. The server's
// timeline has no holes (a still scene is left out of it), so the playhead never waits for a
// gap; it can still lag (the element started late, a busy page), so it is moved to the newest
// picture once it lags by more than LIVE_LAG_S. What has been played is removed, so that memory
// stays bounded however long the stream runs (KeyFrameTimes says where a removal may end).

// The stream parameters and the MIME type of each codec the page plays this way. The codecs
// strings are what isTypeSupported is asked before a stream is opened; the SourceBuffer is made
// with the response's own X-Myriad-Codec (H.264's level depends on the size and rate).
export const MSE_FORMATS = {
  vp9: {container: 'webm', mime: 'video/webm', codecs: 'vp09.00.10.08'},
  vp8: {container: 'webm', mime: 'video/webm', codecs: 'vp8'},
  h264: {container: 'mp4', mime: 'video/mp4', codecs: 'avc1.42C01F'},
};

// The playhead is moved to the live edge when it is this far behind the newest buffered time, to
// LIVE_MARGIN_S before that edge (inside the newest picture: seeking to the very end would show
// nothing until the next one comes).
const LIVE_LAG_S = 0.5;
const LIVE_MARGIN_S = 0.03;
// What stays buffered behind the playhead: from the last key frame at least this far back (a
// removal may only end at a key frame: the frames after one depend on it, and the browser
// removes them all up to the next key frame, the picture playing included).
const KEEP_BEHIND_S = 3;
// ... and a removal is made only once it frees at least this much (each one costs the element
// some work; key frames come at least every 10 s, so buffered stays under about 10 + 3 + 2 s).
const MIN_REMOVAL_S = 2;

// Whether this browser plays `codec` (a key of MSE_FORMATS) through Media Source Extensions:
// {supported, why}. MediaSource exists in insecure contexts too (unlike WebCodecs).
export function mseSupport(codec) {
  const format = MSE_FORMATS[codec];
  if (!format) return {supported: false, why: `${codec} is not played through Media Source Extensions`};
  if (typeof globalThis.MediaSource === 'undefined') {
    return {supported: false, why: 'Media Source Extensions are unavailable here'};
  }
  const type = `${format.mime}; codecs="${format.codecs}"`;
  return MediaSource.isTypeSupported(type) ? {supported: true, why: ''}
                                           : {supported: false, why: `this browser cannot play ${type}`};
}

// The times (seconds) of the key frames in a WebM or fragmented MP4 byte stream, read as bytes
// arrive (split anywhere): where a removal of played media may end. Reads only what says that:
// WebM's TimestampScale, Cluster Timestamps and SimpleBlock key flags; MP4's mdhd timescale and
// per fragment tfhd/trun sample flags with tfdt's decode time. Everything else is skipped
// unread, so a large frame costs no copy. Pure (no DOM).
export class KeyFrameTimes {
  constructor(container) {
    this.webm = container === 'webm';
    this.buffer = new Uint8Array(0);
    this.skip = 0;          // bytes of the current element or box still to pass over
    this.times = [];        // key frame times, ascending
    this.lastWasBlock = false;  // the last element read (or being skipped) is a WebM SimpleBlock
    // WebM: the bytes fed so far end exactly at the end of a SimpleBlock (see clusterRestart).
    this.blockEnded = false;
    // WebM
    this.scale = 1e-3;      // seconds per timestamp tick (TimestampScale 1,000,000 ns)
    this.cluster = 0;       // the current Cluster's Timestamp
    // MP4
    this.timescale = 90000;
    this.defaultFlags = 0;  // tfhd's default sample flags of the current fragment
    this.decodeTime = 0;    // tfdt's of the current fragment
  }

  feed(bytes) {
    if (this.skip >= bytes.length) {
      this.skip -= bytes.length;
      this.blockEnded = this.lastWasBlock && this.skip === 0;
      return;
    }
    bytes = bytes.subarray(this.skip);
    this.skip = 0;
    this.buffer = this.buffer.length ? concat(this.buffer, bytes) : bytes;
    let at = 0;
    for (;;) {
      const used = this.webm ? this.webmElement(at) : this.mp4Box(at);
      if (used === 0) break;
      at += used;
      if (at > this.buffer.length) {  // an element to skip that is not all here yet
        this.skip = at - this.buffer.length;
        at = this.buffer.length;
        break;
      }
    }
    this.buffer = this.buffer.slice(at);
    this.blockEnded = this.lastWasBlock && this.skip === 0 && this.buffer.length === 0;
  }

  // WebM: a Cluster header (unknown size) with the current Cluster's Timestamp, to append right
  // after a SimpleBlock: the same timeline, but the Cluster before it ends there. Chromium's WebM
  // parser holds a Cluster's last block back until the Cluster ends (its duration is the time to
  // the next block), and the server's Clusters end only at the next key frame: without this the
  // newest picture showed only once the next came (a frame late; a still scene's, never).
  clusterRestart() {
    const bytes = new Uint8Array(4 + 8 + 2 + 8);
    bytes.set([0x1F, 0x43, 0xB6, 0x75, 0x01, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xE7, 0x88]);
    new DataView(bytes.buffer).setBigUint64(14, BigInt(this.cluster));
    return bytes;
  }

  // Keeps the list short: only the key frames after `time` and the last one before it matter.
  forgetBefore(time) {
    let i = 0;
    while (i + 1 < this.times.length && this.times[i + 1] <= time) ++i;
    if (i > 0) this.times.splice(0, i);
  }

  // The newest key frame at or before `time`, or null.
  lastAtOrBefore(time) {
    let found = null;
    for (const t of this.times) if (t <= time) found = t;
    return found;
  }

  push(time) {
    if (!this.times.length || time > this.times[this.times.length - 1]) this.times.push(time);
  }

  // One EBML element at `at`: the bytes consumed (its header for an element whose children follow,
  // header and data for any other; may run past the buffer, to be skipped), or 0 to wait for more.
  webmElement(at) {
    const b = this.buffer;
    const id = vint(b, at, true);
    if (!id) return 0;
    const size = vint(b, at + id.length, false);
    if (!size) return 0;
    const header = id.length + size.length;
    const data = at + header;
    this.lastWasBlock = id.value === 0xA3;
    switch (id.value) {
      case 0x18538067:  // Segment, Cluster, Info: their children follow (sizes may be unknown)
      case 0x1F43B675:
      case 0x1549A966:
        return header;
      case 0x2AD7B1:    // TimestampScale (ns)
      case 0xE7: {      // Cluster Timestamp
        if (b.length < data + size.value) return 0;
        let value = 0;
        for (let i = 0; i < size.value; ++i) value = value * 256 + b[data + i];
        if (id.value === 0xE7) this.cluster = value;
        else this.scale = value * 1e-9;
        return header + size.value;
      }
      case 0xA3: {      // SimpleBlock: track number, int16 relative timestamp, flags
        const track = vint(b, data, false);
        if (!track || b.length < data + track.length + 3) return 0;
        const at2 = data + track.length;
        const relative = ((b[at2] << 24) >> 16) | b[at2 + 1];
        if (b[at2 + 2] & 0x80) this.push((this.cluster + relative) * this.scale);
        return header + size.value;
      }
      default:
        if (size.value === Infinity) return header;  // an unknown-size element: enter it
        return header + size.value;
    }
  }

  // One ISO BMFF box at `at`, as webmElement.
  mp4Box(at) {
    const b = this.buffer;
    if (b.length < at + 8) return 0;
    const view = new DataView(b.buffer, b.byteOffset, b.length);
    let size = view.getUint32(at);
    const type = String.fromCharCode(b[at + 4], b[at + 5], b[at + 6], b[at + 7]);
    let header = 8;
    if (size === 1) {
      if (b.length < at + 16) return 0;
      size = Number(view.getBigUint64(at + 8));
      header = 16;
    }
    if (size < header) throw new Error(`MP4 box ${type} of ${size} bytes`);
    const data = at + header;
    switch (type) {
      case 'moov': case 'trak': case 'mdia': case 'moof': case 'traf':
        return header;  // their children follow
      case 'mdhd': case 'tfhd': case 'tfdt': case 'trun':
        if (b.length < at + size) return 0;
        this.mp4Leaf(type, view, data, at + size);
        return size;
      default:
        return size;
    }
  }

  mp4Leaf(type, view, data, end) {
    const version = view.getUint8(data);
    const flags = view.getUint32(data) & 0xFFFFFF;
    let at = data + 4;
    if (type === 'mdhd') {
      at += version === 1 ? 16 : 8;  // creation and modification times
      this.timescale = view.getUint32(at) || this.timescale;
    } else if (type === 'tfhd') {
      at += 4;  // track ID
      if (flags & 0x01) at += 8;   // base data offset
      if (flags & 0x02) at += 4;   // sample description index
      if (flags & 0x08) at += 4;   // default duration
      if (flags & 0x10) at += 4;   // default size
      this.defaultFlags = flags & 0x20 ? view.getUint32(at) : 0;
    } else if (type === 'tfdt') {
      this.decodeTime = version === 1 ? Number(view.getBigUint64(at)) : view.getUint32(at);
    } else if (view.getUint32(at) > 0) {  // trun with samples: is its first a sync sample?
      at += 4;  // sample count
      if (flags & 0x01) at += 4;  // data offset
      let sampleFlags = this.defaultFlags;
      if (flags & 0x04) {
        sampleFlags = view.getUint32(at);
      } else {
        if (flags & 0x100) at += 4;  // the first sample's duration
        if (flags & 0x200) at += 4;  // and size
        if (flags & 0x400 && at + 4 <= end) sampleFlags = view.getUint32(at);
      }
      // sample_is_non_sync_sample (ISO/IEC 14496-12 8.8.3.1)
      if (!(sampleFlags & 0x10000)) this.push(this.decodeTime / this.timescale);
    }
  }
}

// An EBML variable-length integer at `at`: {value, length}, or null when not all here. An ID
// keeps its length marker (0x1A45DFA3); a size of all ones is unknown (Infinity).
function vint(b, at, keepMarker) {
  if (at >= b.length) return null;
  const first = b[at];
  let length = 1;
  while (length <= 8 && !(first & (0x100 >> length))) ++length;
  if (length > 8) throw new Error('WebM: an invalid element header');
  if (at + length > b.length) return null;
  let value = keepMarker ? first : first & (0xFF >> length);
  let allOnes = value === (0xFF >> length);
  for (let i = 1; i < length; ++i) {
    value = value * 256 + b[at + i];
    allOnes = allOnes && b[at + i] === 0xFF;
  }
  return {value: !keepMarker && allOnes ? Infinity : value, length};
}

function concatAll(pieces) {
  const joined = new Uint8Array(pieces.reduce((sum, p) => sum + p.length, 0));
  let at = 0;
  for (const p of pieces) {
    joined.set(p, at);
    at += p.length;
  }
  return joined;
}

function concat(a, b) {
  const joined = new Uint8Array(a.length + b.length);
  joined.set(a);
  joined.set(b, a.length);
  return joined;
}

// Plays one stream's bytes in `video` (a <video> element of its own: the view swaps it in once
// it shows its first picture). feed(bytes) as they arrive, in order. onPicture({width, height,
// sequence, bytes}) after each picture the element presents (sequence: pictures of this stream
// so far; bytes: stream bytes since the last picture); onError(error) when the element or the
// SourceBuffer fails (the caller opens a new stream, which starts with a key frame).
export class MsePlayer {
  constructor(video, format, type, {onPicture = () => {}, onError = () => {}} = {}) {
    this.video = video;
    this.type = type;         // the SourceBuffer's MIME type with codecs
    this.onPicture = onPicture;
    this.onError = onError;
    this.queue = [];          // pieces waiting for the SourceBuffer
    this.buffer = null;       // the SourceBuffer, once the MediaSource opened
    this.keys = new KeyFrameTimes(format.container);
    this.bytes = 0;           // stream bytes since the last picture
    this.pictures = 0;
    this.closed = false;
    this.disposed = false;

    this.source = new MediaSource();
    this.url = URL.createObjectURL(this.source);
    video.muted = true;       // a muted element may play without a user gesture
    video.playsInline = true;
    video.disablePictureInPicture = true;
    video.addEventListener('error', () => this.fail(new Error(`video: ${video.error?.message || 'error'}`)));
    this.source.addEventListener('sourceopen', () => this.open(), {once: true});
    video.src = this.url;
    this.watchPictures();
  }

  open() {
    if (this.closed) return;
    try {
      this.buffer = this.source.addSourceBuffer(this.type);
    } catch (e) {
      this.fail(e);
      return;
    }
    // The stream's own timestamps (from 0, without holes) place each frame.
    this.buffer.mode = 'segments';
    this.buffer.addEventListener('updateend', () => this.updated());
    this.buffer.addEventListener('error', () => this.fail(new Error('SourceBuffer error')));
    // A live source has no end: the element does not wait for one to start.
    this.source.duration = Infinity;
    this.pump();
  }

  feed(bytes) {
    if (this.closed) return;
    this.bytes += bytes.byteLength;
    this.keys.feed(bytes);
    this.queue.push(bytes);
    if (this.keys.blockEnded) this.queue.push(this.keys.clusterRestart());
    this.pump();
  }

  // The next piece to the SourceBuffer, or a removal of played media, when it is idle.
  pump() {
    const buffer = this.buffer;
    if (this.closed || !buffer || buffer.updating || this.source.readyState !== 'open') return;
    if (this.trim()) return;
    if (!this.queue.length) return;
    // Pieces that came meanwhile go in one append (one parse, one updateend).
    const piece = this.queue.length === 1 ? this.queue[0] : concatAll(this.queue);
    this.queue = [];
    try {
      buffer.appendBuffer(piece);
    } catch (e) {
      // QuotaExceededError: the browser's memory for this element is full (trim() keeps it to
      // some seconds, so only a playhead that stopped gets here): a new stream starts clean.
      this.fail(e);
    }
  }

  updated() {
    if (this.closed) return;
    this.keepLive();
    if (this.video.paused && this.video.readyState >= HTMLMediaElement.HAVE_CURRENT_DATA) {
      this.video.play().catch(() => {});  // refused (autoplay policy): the next append tries again
    }
    this.pump();
  }

  // The playhead to the newest picture when it lags (a page in a background tab, a busy
  // machine), or when it is in no buffered range. A seek decodes again from the key frame before
  // its target, which takes a while: none while one is under way.
  keepLive() {
    const ranges = this.buffer.buffered;
    if (!ranges.length || this.video.seeking) return;
    const end = ranges.end(ranges.length - 1);
    const start = ranges.start(ranges.length - 1);
    const now = this.video.currentTime;
    if (end - now > LIVE_LAG_S || now < start) {
      this.video.currentTime = Math.max(start, end - LIVE_MARGIN_S);
    }
  }

  // Starts a removal of media played more than KEEP_BEHIND_S ago, up to a key frame; true when
  // one started (the SourceBuffer is busy until its updateend).
  trim() {
    const ranges = this.buffer.buffered;
    if (!ranges.length) return false;
    const keepFrom = this.keys.lastAtOrBefore(this.video.currentTime - KEEP_BEHIND_S);
    if (keepFrom === null || keepFrom - ranges.start(0) < MIN_REMOVAL_S) return false;
    this.buffer.remove(0, keepFrom);
    this.keys.forgetBefore(keepFrom);
    return true;
  }

  // Each picture the element presents (requestVideoFrameCallback: once per painted frame, with
  // its size); without it, each time the playhead moves.
  watchPictures() {
    const picture = (width, height) => {
      if (this.disposed) return;
      this.pictures += 1;
      const bytes = this.bytes;
      this.bytes = 0;
      this.onPicture({width, height, sequence: this.pictures, bytes});
    };
    if ('requestVideoFrameCallback' in HTMLVideoElement.prototype) {
      const next = () => {
        if (this.disposed) return;
        this.video.requestVideoFrameCallback((now, meta) => {
          picture(meta.width, meta.height);
          next();
        });
      };
      next();
    } else {
      this.video.addEventListener('timeupdate', () => picture(this.video.videoWidth, this.video.videoHeight));
    }
  }

  fail(error) {
    if (this.closed) return;
    this.onError(error);
  }

  // No more bytes (the stream ended or was replaced): the element keeps its last picture on
  // screen until the view disposes of it.
  close() {
    this.closed = true;
    this.queue = [];
  }

  // Gone from the page: the MediaSource and its memory are released now, not at the next GC.
  dispose() {
    if (this.disposed) return;
    this.close();
    this.disposed = true;
    this.video.removeAttribute('src');
    this.video.load();
    URL.revokeObjectURL(this.url);
    this.video.remove();
  }
}
