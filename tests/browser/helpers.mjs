// Helpers of the browser test that need no page or server: waiting, checking, and the picture
// signature compared between frames.

export const WAIT_MS = 30000;

export function check(condition, message) {
  if (!condition) throw new Error(message);
}

export async function until(what, probe, timeoutMs = WAIT_MS, intervalMs = 150) {
  const end = Date.now() + timeoutMs;
  let last;
  for (;;) {
    last = await probe();
    if (last) return last;
    if (Date.now() > end) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await new Promise((r) => setTimeout(r, intervalMs));
  }
}

// The picture in the view as 32x32 mean colours, from what shows it (same origin, so a canvas
// can read it): the video canvas (#video, WebCodecs) once it shows a decoded picture, or the
// <video id="video"> (Media Source Extensions) once it presents one, else the <img> of the
// JPEG stream. What the user sees, not a screenshot of the page around it.
export function signatureInPage() {
  const video = document.getElementById('video');
  const img = document.getElementById('stream');
  let source;
  let width;
  let height;
  let shownFrom;
  if (video instanceof HTMLVideoElement && video.dataset.shown && video.videoWidth > 0) {
    // Media Source Extensions: the <video>'s current picture.
    source = video;
    width = video.videoWidth;
    height = video.videoHeight;
    shownFrom = video;
  } else if (video && video.dataset.shown && video.width > 0) {
    source = video;
    width = video.width;
    height = video.height;
    shownFrom = video;
  } else {
    if (!img.complete || img.naturalWidth === 0) return null;
    source = img;
    width = img.naturalWidth;
    height = img.naturalHeight;
    shownFrom = img;
  }
  const n = 32;
  const c = document.createElement('canvas');
  c.width = width;
  c.height = height;
  const g = c.getContext('2d', {willReadFrequently: true});
  g.drawImage(source, 0, 0);
  const {data} = g.getImageData(0, 0, c.width, c.height);
  const sums = new Float64Array(n * n * 3);
  const counts = new Float64Array(n * n);
  for (let y = 0; y < c.height; ++y) {
    for (let x = 0; x < c.width; ++x) {
      const cell = Math.floor((y * n) / c.height) * n + Math.floor((x * n) / c.width);
      const i = (y * c.width + x) * 4;
      sums[cell * 3] += data[i];
      sums[cell * 3 + 1] += data[i + 1];
      sums[cell * 3 + 2] += data[i + 2];
      counts[cell] += 1;
    }
  }
  const sig = Array.from(sums, (s, i) => s / Math.max(1, counts[Math.floor(i / 3)]));
  // src: the stream the shown part came from (the view keeps it in data-shown); frame: its
  // X-Myriad-Frame number.
  // interactive: the part's X-Myriad-Interactive render scale ('' for a full-quality part).
  return {width, height, src: shownFrom.dataset.shown || '', frame: Number(shownFrom.dataset.frame),
          interactive: shownFrom.dataset.interactive || '',
          codec: document.getElementById('view').dataset.codec || '', sig};
}

// The largest change of one cell (of 32x32, 0..255): what a local change (a light on one corner of
// the scene) moves, where the mean over the whole picture hardly moves.
export function largestCellDifference(a, b) {
  let most = 0;
  for (let i = 0; i < a.sig.length; ++i) most = Math.max(most, Math.abs(a.sig[i] - b.sig[i]));
  return most;
}

export function difference(a, b) {
  let sum = 0;
  for (let i = 0; i < a.sig.length; ++i) sum += Math.abs(a.sig[i] - b.sig[i]);
  return sum / a.sig.length;
}
