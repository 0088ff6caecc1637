#version 450
#extension GL_GOOGLE_include_directive : require
// Stochastic local shadows (render/stochastic_shadows.h): the clustered technique's shading step
// when settings.shadows.local is stochastic. Each pixel shades sun + ambient as every technique
// does (sunAndAmbient; where the sun casts shadows, one ray towards it instead of its map), then
// estimates the sum of its cluster's lights' shadowed light with one shadow ray:
//   candidates  each light of the pixel's cluster list (L lights) is a candidate with probability
//               q = min(1, M / L), M = FrameUniforms.stochastic.y (tuning stochastic-candidates):
//               a list no longer than M is taken whole;
//   resampling  among the candidates S reaching the pixel, one, y, is kept with probability
//               p^(y) / sum_S p^, p^ the luminance of its unshadowed light (shadeLight):
//               resampled importance sampling (Talbot 2005; the reservoir of ReSTIR, Bitterli 2020),
//               drawn as the largest log(u) / p^ (Efraimidis and Spirakis 2006), so the choice does
//               not depend on the list's order (the lists are filled by atomics);
//   shadow ray  one, from the surface to y's light through the scene's BVH (bvh_trace.glsl);
//   estimate    f(y) V(y) sum_S p^ / (q p^(y)): unbiased for the sum over the list of f V, as
//               E[sum over S of f V / q] is (p^ > 0 wherever f is: p^ is f's luminance). A whole
//               list weighs each light by its unshadowed light exactly, so a pixel that every light
//               sees gets the exact unshadowed sum and the noise is the shadows' alone.
// The random numbers hash the pixel, the frame's seed (FrameSettings::sampleIndex) and the light's
// index. The light-count target counts the candidates reaching the pixel (with a whole list,
// every light: the other techniques' count).
#include "frame.glsl"
#include "compute_targets.glsl"
#define MYRIAD_BVH_TRACE_SET MYRIAD_SET_MATERIAL  // set 3 of this pass's layout
#include "bvh_trace.glsl"

layout(local_size_x = MYRIAD_CLUSTER_SHADE_TILE, local_size_y = MYRIAD_CLUSTER_SHADE_TILE) in;

// PCG (O'Neill 2014) as a hash (Jarzynski and Olano, JCGT 2020).
uint pcgHash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// A uniform number in [0, 1) from a hash.
float unitFloat(uint h) { return float(h >> 8u) * (1.0 / 16777216.0); }

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  Surface s;
  if (!loadSurfaceWithDepth(pixel, depth, s)) {
    imageStore(hdrOut, pixel, vec4(backgroundRadiance(pixel), 1.0));
    imageStore(lightCountOut, pixel, vec4(0.0));
    return;
  }
  vec3 color = sunAndAmbient(s);
  BrdfSurface b = brdfSurfaceOf(s);
  vec3 origin = s.position + s.normal * uintBitsToFloat(frame.stochastic.w);
  // The sun casts shadows and this frame traces them (no map was drawn, so sunAndAmbient lit the
  // point unshadowed): a ray towards the sun, and its light off where it is blocked.
  if ((frame.stochastic.z & MYRIAD_STOCHASTIC_TRACE_SUN) != 0u &&
      dot(s.normal, frame.sunDirection.xyz) > 0.0 &&
      bvhOccluded(origin, frame.sunDirection.xyz, 0.0, 3.0e38)) {
    color = max(color - brdfCosineAt(b, frame.sunDirection.xyz) *
                            (frame.sunColor.rgb * frame.sunDirection.w), vec3(0.0));
  }
  uint slice = sliceOfViewDepth(viewDepthFromDepth(depth));
  uvec2 range = clusterRanges[clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice))];
  uint listLength = range.y;
  float q = min(1.0, float(max(frame.stochastic.y, 1u)) / float(max(listLength, 1u)));
  uint pixelSeed = pcgHash(uint(pixel.x) + pcgHash(uint(pixel.y) + pcgHash(frame.stochastic.x)));

  float weightSum = 0.0;
  float bestKey = uintBitsToFloat(0xFF800000u);  // -infinity: the first candidate wins
  uint chosen = MYRIAD_BVH_NONE;
  vec3 chosenLight = vec3(0.0);
  float chosenTarget = 0.0;
  uint reached = 0u;
  for (uint k = 0u; k < listLength; ++k) {
    uint index = clusterLights[range.x + k];
    uint h = pcgHash(index ^ pixelSeed);
    if (q < 1.0 && unitFloat(h) >= q) continue;
    if (!lightReaches(s, index)) continue;
    ++reached;
    vec3 light = shadeLightAt(b, s, index);
    float target = luminance(light);
    if (!(target > 0.0)) continue;
    weightSum += target;
    float key = log(unitFloat(pcgHash(h)) + 0.5 / 16777216.0) / target;
    if (key >= bestKey) {
      bestKey = key;
      chosen = index;
      chosenLight = light;
      chosenTarget = target;
    }
  }
  if (chosen != MYRIAD_BVH_NONE) {
    vec3 toLight = lights[chosen].positionRadius.xyz - s.position;
    vec3 ray = lights[chosen].positionRadius.xyz - origin;
    // t in (0, 1) along the segment to the light: the light itself is never an occluder.
    if (dot(s.normal, toLight) > 0.0 && !bvhOccluded(origin, ray, 0.0, 1.0)) {
      float W = weightSum / (q * chosenTarget);
      color += chosenLight * W;
    }
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
