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
