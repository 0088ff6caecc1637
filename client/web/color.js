// The API speaks linear RGB; <input type=color> speaks sRGB hex. These convert between the two
// with the sRGB transfer function, so a picked colour renders as the colour that was picked.

function toSrgb(linear) {
  const c = Math.min(1, Math.max(0, linear));
  return c <= 0.0031308 ? c * 12.92 : 1.055 * Math.pow(c, 1 / 2.4) - 0.055;
}

function toLinear(srgb) {
  return srgb <= 0.04045 ? srgb / 12.92 : Math.pow((srgb + 0.055) / 1.055, 2.4);
}

// [r, g, b] linear in [0, 1] -> "#rrggbb".
export function linearToHex(rgb) {
  return '#' + rgb.map((c) => Math.round(toSrgb(c) * 255).toString(16).padStart(2, '0')).join('');
}

// "#rrggbb" -> [r, g, b] linear, rounded to 4 decimals so the JSON stays short.
export function hexToLinear(hex) {
  const rgb = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
  return rgb.map((c) => Math.round(toLinear(c) * 10000) / 10000);
}

// A colour above 1 (sun and ambient go to 64) as a hue in [0, 1] and a strength: the picker
// shows the hue, a slider the strength; colour = hue * strength.
export function splitStrength(rgb) {
  const strength = Math.max(rgb[0], rgb[1], rgb[2]);
  return strength > 0 ? {hue: rgb.map((c) => c / strength), strength} : {hue: [1, 1, 1], strength: 0};
}
