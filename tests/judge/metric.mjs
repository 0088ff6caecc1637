// How the judge compares Myriad's linear radiance with three.js's (docs/ARCHITECTURE.md, section 9,
// "The independent judge", says why each rule is what it is).
//
// Pixels compared: covered by geometry in both images, and more than 2 pixels away from a
// silhouette of either image and from a depth jump in Myriad's depth (where the two rasterisers
// may pick different triangles). Per compared pixel, the relative colour
// error
//     e = max_c |M_c - T_c| / (max_c T_c + tau),   tau = 0.02 * W,
// W = the 99th percentile of max_c T_c over the compared pixels (the scene's white), so dark
// pixels are judged against 2% of white rather than against their own near-zero value. Besides
// the error's mean and 95th percentile: the bias (sum of M over sum of T, per channel, each value
// counted up to BIAS_CLAMP x W), and the coverage: pixels covered by one image only that are not
// on a silhouette of either.

export const BAND = 2;  // pixels excluded on each side of a silhouette or depth edge
// In the bias sums a value counts up to this many times the white W. A point light's highlight on
// a near-mirror texel is a near-delta: single pixels hundreds of times W, whose exact value
// depends on where each rasteriser's pixel centre and filtered normal land (DamagedHelmet at
// 512x512: five pixels of 82-389 W carried 2% of the image's light, Myriad 389 and 213 where
// three.js had 323 and 82). Unclamped, the bias measured those few pixels; a display saturates
// far below 4 W, and a systematic error (every light 4% brighter) still moves every other pixel.
export const BIAS_CLAMP = 4;

function percentile(sorted, p) {
  if (sorted.length === 0) return NaN;
  return sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
}

// M: Float32Array, `stride` floats per pixel, r g b first (Myriad's raw final: 3), depth:
// Float32Array (Myriad's raw depth, `far` off the geometry: it says where M has geometry),
// T: Float32Array rgba from three.js (alpha 0 off the geometry).
// `block` > 1 judges block means instead of pixels: the blocks of block x block pixels that are
// compared whole (for minified, high-frequency textures, where two GPUs' texture filtering
// legitimately differs texel by texel; a systematic error survives the averaging).
export function compare(width, height, M, depth, far, T, stride = 3, block = 1) {
  const n = width * height;
  const nonFinite = {myriad: 0, three: 0};
  const covM = new Uint8Array(n);
  const covT = new Uint8Array(n);
  const inverseDepth = new Float32Array(n);
  for (let i = 0; i < n; ++i) {
    for (let c = 0; c < 3; ++c) {
      if (!Number.isFinite(M[i * stride + c])) ++nonFinite.myriad;
      if (!Number.isFinite(T[i * 4 + c])) ++nonFinite.three;
    }
    covM[i] = depth[i] < far * (1 - 1e-5) ? 1 : 0;
    covT[i] = T[i * 4 + 3] > 0 ? 1 : 0;
    inverseDepth[i] = covM[i] ? 1 / depth[i] : 0;
  }
  // Edges: neighbours (4-connected) with other coverage in either image, or, both covered, a
  // depth jump: 1/depth (affine in screen space on a plane) changes between them by more than 0.2%
  // and by more than 3 times its change on either side (so the slope of a grazing plane and the
  // crease between two facets of one surface are not edges; one surface behind another is).
  const edge = new Uint8Array(n);
  const at = (x, y) => y * width + x;
  const step = (a, b) => (covM[a] && covM[b] ? Math.abs(inverseDepth[a] - inverseDepth[b]) : 0);
  for (let y = 0; y < height; ++y) {
    for (let x = 0; x < width; ++x) {
      const i = at(x, y);
      for (const [dx, dy] of [[1, 0], [0, 1]]) {
        const x1 = x + dx;
        const y1 = y + dy;
        if (x1 >= width || y1 >= height) continue;
        const j = at(x1, y1);
        if (covM[i] !== covM[j] || covT[i] !== covT[j]) {
          edge[i] = edge[j] = 1;
          continue;
        }
        if (!covM[i]) continue;
        const jump = step(i, j);
        const before = x - dx >= 0 && y - dy >= 0 ? step(at(x - dx, y - dy), i) : 0;
        const after = x1 + dx < width && y1 + dy < height ? step(j, at(x1 + dx, y1 + dy)) : 0;
        if (jump > 0.002 * inverseDepth[i] && jump > 3 * Math.max(before, after)) edge[i] = edge[j] = 1;
      }
    }
  }
  const band = new Uint8Array(n);
  for (let y = 0; y < height; ++y) {
    for (let x = 0; x < width; ++x) {
      if (!edge[at(x, y)]) continue;
      for (let dy = -BAND; dy <= BAND; ++dy) {
        for (let dx = -BAND; dx <= BAND; ++dx) {
          const x1 = x + dx;
          const y1 = y + dy;
          if (x1 >= 0 && y1 >= 0 && x1 < width && y1 < height) band[at(x1, y1)] = 1;
        }
      }
    }
  }

  let coveredM = 0;
  let coveredT = 0;
  let coverageMismatch = 0;
  const compared = [];
  for (let i = 0; i < n; ++i) {
    coveredM += covM[i];
    coveredT += covT[i];
    if (covM[i] !== covT[i] && !band[i]) ++coverageMismatch;
    if (covM[i] && covT[i] && !band[i]) compared.push(i);
  }
  let blockGeometry = null;
  if (block > 1) {
    // Block means of M and T over the blocks whose pixels are all compared; the same statistics
    // follow, over blocks (M3, T4 and `compared` now index the block image).
    const bw = Math.floor(width / block);
    const bh = Math.floor(height / block);
    const M3 = new Float32Array(bw * bh * 3);
    const T4 = new Float32Array(bw * bh * 4);
    const isCompared = new Uint8Array(n);
    for (const i of compared) isCompared[i] = 1;
    const blocks = [];
    for (let by = 0; by < bh; ++by) {
      for (let bx = 0; bx < bw; ++bx) {
        let whole = true;
        const b = by * bw + bx;
        for (let y = by * block; y < (by + 1) * block && whole; ++y) {
          for (let x = bx * block; x < (bx + 1) * block; ++x) {
            const i = y * width + x;
            if (!isCompared[i]) {
              whole = false;
              break;
            }
            for (let c = 0; c < 3; ++c) {
              M3[b * 3 + c] += M[i * stride + c] / (block * block);
              T4[b * 4 + c] += T[i * 4 + c] / (block * block);
            }
          }
        }
        if (whole) blocks.push(b);
      }
    }
    M = M3;
    T = T4;
    stride = 3;
    compared.length = 0;
    compared.push(...blocks);
    // Where each block's error goes in the full-size error map.
    blockGeometry = {bw, bh};
  }
  const peaks = compared.map((i) => Math.max(T[i * 4], T[i * 4 + 1], T[i * 4 + 2])).sort((a, b) => a - b);
  const white = percentile(peaks, 0.99);
  const tau = 0.02 * white;
  const cap = BIAS_CLAMP * white;
  const errors = new Float32Array(n).fill(NaN);
  const sums = {m: [0, 0, 0], t: [0, 0, 0]};
  const list = [];
  for (const i of compared) {
    let diff = 0;
    let peak = 0;
    for (let c = 0; c < 3; ++c) {
      diff = Math.max(diff, Math.abs(M[i * stride + c] - T[i * 4 + c]));
      peak = Math.max(peak, T[i * 4 + c]);
      sums.m[c] += Math.min(M[i * stride + c], cap);
      sums.t[c] += Math.min(T[i * 4 + c], cap);
    }
    const e = diff / (peak + tau);
    errors[i] = (M[i * stride] + M[i * stride + 1] + M[i * stride + 2] >= T[i * 4] + T[i * 4 + 1] + T[i * 4 + 2]) ? e : -e;
    list.push(e);
  }
  if (blockGeometry) {
    const blockErrors = errors.slice(0, blockGeometry.bw * blockGeometry.bh);
    errors.fill(NaN);
    for (let y = 0; y < blockGeometry.bh * block; ++y) {
      for (let x = 0; x < blockGeometry.bw * block; ++x) {
        errors[y * width + x] = blockErrors[Math.floor(y / block) * blockGeometry.bw + Math.floor(x / block)];
      }
    }
  }
  list.sort((a, b) => a - b);
  const mean = list.reduce((s, e) => s + e, 0) / Math.max(1, list.length);
  return {
    stats: {
      pixels: blockGeometry ? blockGeometry.bw * blockGeometry.bh : n, block, coveredMyriad: coveredM, coveredThree: coveredT, compared: compared.length,
      coverageMismatch, nonFinite, white,
      bias: [0, 1, 2].map((c) => (sums.t[c] > 0 ? sums.m[c] / sums.t[c] - 1 : 0)),
      mean, p95: percentile(list, 0.95), p99: percentile(list, 0.99), max: list.at(-1) ?? NaN,
    },
    errors, covM, covT, band,
  };
}

// The verdict of one comparison under `tolerance` {mean, p95, bias, coverage}: a list of the
// rules broken, each a sentence with the measured value (empty: it passes).
export function verdict(stats, tolerance) {
  const broken = [];
  const f = (v, d = 4) => Number(v).toFixed(d);
  if (stats.nonFinite.myriad) broken.push(`${stats.nonFinite.myriad} NaN/Inf values in Myriad's raw final`);
  if (stats.nonFinite.three) broken.push(`${stats.nonFinite.three} NaN/Inf values in three.js's image`);
  if (stats.compared < 0.05 * stats.pixels) {
    broken.push(`only ${stats.compared} of ${stats.pixels} pixels comparable (the scene is not in view?)`);
  }
  if (!(stats.white > 0)) broken.push('three.js rendered the scene black');
  const coverage = stats.coverageMismatch / Math.max(1, Math.max(stats.coveredMyriad, stats.coveredThree));
  if (coverage > tolerance.coverage) {
    broken.push(`${stats.coverageMismatch} pixels (${f(coverage * 100, 2)}% of the covered) are ` +
                `geometry in one image only, away from silhouettes (limit ${tolerance.coverage * 100}%)`);
  }
  if (!(stats.mean <= tolerance.mean)) broken.push(`mean relative error ${f(stats.mean)} > ${tolerance.mean}`);
  if (!(stats.p95 <= tolerance.p95)) broken.push(`95th percentile relative error ${f(stats.p95)} > ${tolerance.p95}`);
  const bias = Math.max(...stats.bias.map(Math.abs));
  if (!(bias <= tolerance.bias)) {
    broken.push(`bias (sum Myriad / sum three.js - 1, r g b) ${stats.bias.map((b) => f(b)).join(' ')} ` +
                `beyond +-${tolerance.bias}`);
  }
  return broken;
}

function srgb(linear) {
  const c = Math.min(1, Math.max(0, linear));
  return Math.round(255 * (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055));
}

// 8-bit RGB pictures for a developer: each image divided by the same white W and sRGB-encoded,
// and the error map: red where Myriad is brighter, blue where darker (full at errorScale).
export function pictures(width, height, M, T, result, errorScale) {
  const n = width * height;
  const white = result.stats.white > 0 ? result.stats.white : 1;
  const myriad = new Uint8Array(n * 3);
  const three = new Uint8Array(n * 3);
  const diff = new Uint8Array(n * 3);
  for (let i = 0; i < n; ++i) {
    for (let c = 0; c < 3; ++c) {
      myriad[i * 3 + c] = srgb(M[i * 3 + c] / white);
      three[i * 3 + c] = srgb(T[i * 4 + c] / white);
    }
    const e = result.errors[i];
    if (Number.isNaN(e)) {
      // yellow: geometry in one image only, away from silhouettes; grey: the excluded band
      // (lighter where only one image has geometry); black: no geometry in either.
      const one = result.covM[i] !== result.covT[i];
      const grey = one ? 140 : result.covM[i] ? 60 : 0;
      diff.set(one && !result.band[i] ? [255, 255, 0] : [grey, grey, grey], i * 3);
    } else {
      const v = Math.round(255 * Math.min(1, Math.abs(e) / errorScale));
      diff.set(e >= 0 ? [v, 0, 0] : [0, 0, v], i * 3);
    }
  }
  return {myriad, three, diff};
}
