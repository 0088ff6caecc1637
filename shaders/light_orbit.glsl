// Where light `index` is at time `t` when lights animate: its origin plus a Lissajous orbit whose
// size, speed and phase come from a hash of the index. Stateless, so any frame is reproducible from
// the scene (origins from the seed) and the time alone. light_animate.comp moves every light with
// it; the clustered technique's counting pass (cluster_assign_binned.comp) does the same while it
// walks the lights; render/shadows.cpp computes it on the CPU, bit for bit the same hash.
#ifndef MYRIAD_LIGHT_ORBIT_GLSL
#define MYRIAD_LIGHT_ORBIT_GLSL

// PCG-style integer hash (Jarzynski & Olano, JCGT 2020) -> [0, 1).
float hash01(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return float((word >> 22u) ^ word) / 4294967296.0;
}

vec4 orbitPosition(uint index, vec4 originRadius, float t) {
  float radius = originRadius.w;
  float speed = 0.4 + 0.8 * hash01(index * 3u);
  float phase = 6.2831853 * hash01(index * 3u + 1u);
  float reach = radius * (0.5 + 0.5 * hash01(index * 3u + 2u));
  vec3 offset = reach * vec3(sin(speed * t + phase), 0.25 * sin(1.7 * speed * t + phase),
                             cos(0.8 * speed * t + phase));
  return vec4(originRadius.xyz + offset, radius);
}

#endif
