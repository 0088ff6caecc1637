// Small 3-vector helpers on plain arrays [x, y, z] (the API's vector form), and the camera
// projection the light picking uses.

export const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
export const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
export const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
export const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                a[0] * b[1] - a[1] * b[0]];
export const length = (a) => Math.hypot(a[0], a[1], a[2]);
export const normalize = (a) => {
  const l = length(a);
  return l > 0 ? scale(a, 1 / l) : [0, 0, 0];
};

// Rodrigues' rotation of v around the unit axis k by angle (radians).
export function rotate(v, k, angle) {
  const c = Math.cos(angle);
  const s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}

// The camera's orthonormal basis: forward (eye to target), right, and the true up.
export function cameraBasis(camera) {
  const forward = normalize(sub(camera.target, camera.eye));
  const right = normalize(cross(forward, camera.up));
  const up = cross(right, forward);
  return {forward, right, up};
}

// Where a world point lands in a width x height view (pixels from the top left), and its view
// depth; null when it is behind the eye. Matches a symmetric perspective with vertical fovY.
export function project(camera, point, width, height) {
  const {forward, right, up} = cameraBasis(camera);
  const d = sub(point, camera.eye);
  const depth = dot(d, forward);
  if (depth <= (camera.near || 1e-4)) return null;
  const f = 1 / Math.tan((camera.fovY * Math.PI) / 360);
  const aspect = width / height;
  const ndcX = (dot(d, right) * f) / (aspect * depth);
  const ndcY = (dot(d, up) * f) / depth;
  return {x: (ndcX * 0.5 + 0.5) * width, y: (0.5 - ndcY * 0.5) * height, depth};
}

// ---- Rotations for the object editor: Euler angles in degrees, applied about x, then y, then
// z (fixed axes: R = Rz Ry Rx), and the API's quaternions [x, y, z, w].

const RADIANS = Math.PI / 180;

// The quaternion of rotations by euler[0], [1], [2] degrees about x, then y, then z.
export function eulerToQuat(euler) {
  const [cx, cy, cz] = euler.map((a) => Math.cos((a * RADIANS) / 2));
  const [sx, sy, sz] = euler.map((a) => Math.sin((a * RADIANS) / 2));
  return [sx * cy * cz - cx * sy * sz,
          cx * sy * cz + sx * cy * sz,
          cx * cy * sz - sx * sy * cz,
          cx * cy * cz + sx * sy * sz];
}

// A rotation matrix as rows (r[row][column]) of the unit quaternion [x, y, z, w].
export function quatToRows([x, y, z, w]) {
  const n = Math.hypot(x, y, z, w) || 1;
  [x, y, z, w] = [x / n, y / n, z / n, w / n];
  return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]];
}

// The Euler degrees (as eulerToQuat takes them) of a rotation matrix given as rows.
export function rowsToEuler(r) {
  const y = Math.asin(Math.max(-1, Math.min(1, -r[2][0])));
  if (Math.abs(r[2][0]) > 0.999999) {
    // Gimbal lock: only x - z (or x + z) is defined; x is taken as 0.
    return [0, y / RADIANS, Math.atan2(-r[0][1], r[1][1]) / RADIANS];
  }
  return [Math.atan2(r[2][1], r[2][2]) / RADIANS, y / RADIANS, Math.atan2(r[1][0], r[0][0]) / RADIANS];
}

// A transform as the API gives it (TRS, or a column-major matrix without shear) as
// {translation, rotation (quaternion), scale, euler (degrees)}.
export function transformParts(transform) {
  if (!transform.matrix) {
    const rotation = transform.rotation || [0, 0, 0, 1];
    return {translation: transform.translation || [0, 0, 0], rotation,
            scale: transform.scale || [1, 1, 1], euler: rowsToEuler(quatToRows(rotation))};
  }
  const m = transform.matrix;
  const column = (c) => [m[4 * c], m[4 * c + 1], m[4 * c + 2]];
  const scaleOf = [0, 1, 2].map((c) => length(column(c)) || 1);
  // A mirroring matrix: one negative scale (on x) keeps the rest a rotation.
  if (dot(cross(column(0), column(1)), column(2)) < 0) scaleOf[0] = -scaleOf[0];
  const rows = [0, 1, 2].map((r) => [0, 1, 2].map((c) => m[4 * c + r] / scaleOf[c]));
  const euler = rowsToEuler(rows);
  return {translation: [m[12], m[13], m[14]], rotation: eulerToQuat(euler), scale: scaleOf, euler};
}

// The quaternion product a * b: the rotation b, then a.
export function quatMultiply([ax, ay, az, aw], [bx, by, bz, bw]) {
  return [aw * bx + ax * bw + ay * bz - az * by,
          aw * by - ax * bz + ay * bw + az * bx,
          aw * bz + ax * by - ay * bx + az * bw,
          aw * bw - ax * bx - ay * by - az * bz];
}

// The quaternion of a turn by `angle` radians about `axis` (any length but zero).
export function axisAngleQuat(axis, angle) {
  const [x, y, z] = normalize(axis);
  const s = Math.sin(angle / 2);
  return [x * s, y * s, z * s, Math.cos(angle / 2)];
}
