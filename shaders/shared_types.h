// Shared by C++ and GLSL: binding indices, constants and GPU struct layouts.
//
// Every struct here is std140/std430-compatible by construction: only vec4, uvec4 and mat4
// members, so the two layouts agree and C++ needs no padding rules. The C++ side checks sizes and
// offsets with static_assert (server/render/gpu_types.h); change a struct here and both sides see it.
#ifndef MYRIAD_SHARED_TYPES_H
#define MYRIAD_SHARED_TYPES_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace myriad::gpu_types {
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#define MYRIAD_STRUCT(name) struct name
#else
#define MYRIAD_STRUCT(name) struct name
#endif

// Descriptor set 0: the scene (changes when the scene changes).
#define MYRIAD_SET_SCENE 0
#define MYRIAD_BINDING_FRAME 0      // uniform FrameUniforms
#define MYRIAD_BINDING_LIGHTS 1     // storage GpuPointLight[]
#define MYRIAD_BINDING_INSTANCES 2  // storage GpuInstance[]
#define MYRIAD_BINDING_MATERIALS 3  // storage GpuMaterial[]
#define MYRIAD_BINDING_LIGHT_ORIGINS 4  // storage GpuPointLight[]: where animation starts from
#define MYRIAD_BINDING_ENVIRONMENT 5    // storage vec4[]: the environment's SH9 irradiance + specular
#define MYRIAD_BINDING_BRDF_LUT 6       // storage vec4[]: the split-sum BRDF table (x scale, y bias)
#define MYRIAD_BINDING_SUN_SHADOW_MAP 7 // sampler2DShadow: the sun's depth from its side (D32)
#define MYRIAD_BINDING_LIGHT_SHADOW_ATLAS 8 // sampler2DShadow: local lights' depth tiles (D32)
// The lights and the materials again, as uniform texel buffers, one texel a vec4/uvec4 member:
// what hot loops read on CPU devices (the whole-list light loop, the G-buffer's material).
// llvmpipe (Mesa 22.3) loads a storage buffer one lane and one component at a time, each behind
// two branches; a texel fetch takes its vectorised texture path. Lights are RGBA32F (all float;
// 2-3 ms faster than RGBA32UI with uintBitsToFloat), materials RGBA32UI (their flags are integer
// bits, which a float format could flush as denormals), read back with uintBitsToFloat.
#define MYRIAD_BINDING_LIGHT_TEXELS 9
#define MYRIAD_BINDING_MATERIAL_TEXELS 10
#define MYRIAD_LIGHT_TEXELS 3  // texels of one GpuPointLight

// Shadows (render/shadows.cpp). The shadow pass draws depth only, with one push constant: the
// light's view-projection (ShadowPush).
#define MYRIAD_SHADOW_MAP_MIN 256
#define MYRIAD_SHADOW_MAP_MAX 4096
#define MYRIAD_SHADOW_MAP_DEFAULT 2048
// The sun's shadow cascades at most (settings shadows.cascades 1..4; render/shadows.h).
#define MYRIAD_MAX_SUN_CASCADES 4
#define MYRIAD_SUN_CASCADES_DEFAULT 4
// Local lights' shadows: at most this many lights a frame get a shadow map (settings.shadows.
// maxShadowedLights, default below). Their depth lives in ONE atlas (no descriptor indexing): a
// spot light takes one square tile (a perspective projection over its cone), a point light (or a
// spot wider than MYRIAD_SPOT_SHADOW_MAX_ANGLE) six, the faces of a cube around it. Tiles are
// mapSize / 4 texels across, between the MIN and MAX below, MYRIAD_SHADOW_ATLAS_COLUMNS a row.
#define MYRIAD_MAX_SHADOWED_LIGHTS 16
#define MYRIAD_SHADOWED_LIGHTS_DEFAULT 4
#define MYRIAD_SHADOW_TILE_MIN 64
#define MYRIAD_SHADOW_TILE_MAX 512
#define MYRIAD_SHADOW_ATLAS_COLUMNS 8
#define MYRIAD_SPOT_SHADOW_MAX_ANGLE 0.95993109f  // 55 degrees: one projection up to 110 + margin
#define MYRIAD_LIGHT_SHADOW_SPOT 0u  // GpuLightShadow.tiles.y: one perspective tile
#define MYRIAD_LIGHT_SHADOW_CUBE 1u  // six tiles, +X -X +Y -Y +Z -Z (shaders/frame.glsl)

// The environment light (shaders/environment.glsl, render/environment.cpp). Sizes are modest so
// lavapipe prefilters in well under a second; all maps are equirectangular (u = longitude,
// v = polar angle from +Y) and live in storage buffers of vec4 (no images, no samplers: every
// lookup is a manual bilinear fetch, which the C++ reference repeats exactly).
#define MYRIAD_ENV_NONE 0  // the constant ambient term (the seed's)
#define MYRIAD_ENV_SKY 1   // the procedural sky, from the sun's direction and colour
#define MYRIAD_ENV_HDR 2   // an uploaded equirectangular Radiance .hdr
#define MYRIAD_ENV_SOURCE_WIDTH 256   // the source radiance map and its box-filtered pyramid
#define MYRIAD_ENV_SOURCE_HEIGHT 128
#define MYRIAD_ENV_SOURCE_LEVELS 6    // 256x128 down to 8x4
#define MYRIAD_ENV_SOURCE_TEXELS 43680  // sum of the pyramid's levels
#define MYRIAD_ENV_SPECULAR_WIDTH 128   // each prefiltered level (perceptual roughness i / 5)
#define MYRIAD_ENV_SPECULAR_HEIGHT 64
#define MYRIAD_ENV_SPECULAR_LEVELS 6
#define MYRIAD_ENV_SPECULAR_SAMPLES 64  // GGX importance samples per specular texel
#define MYRIAD_ENV_HEADER 16            // vec4s before the specular levels: 9 SH coefficients
#define MYRIAD_ENV_SH_LEVEL 2           // the SH projection sums this source level (64x32)
#define MYRIAD_BRDF_LUT_SIZE 32         // N.V across, perceptual roughness down
#define MYRIAD_BRDF_LUT_SAMPLES 256
#define MYRIAD_ENV_GROUP 64             // workgroup size of the environment's compute passes
#define MYRIAD_ENV_BINDING_SOURCE 0     // the environment passes' own set 0 (environment_pass.glsl)
#define MYRIAD_ENV_BINDING_LIGHTING 1
#define MYRIAD_ENV_BINDING_LUT 2

// Descriptor set 1: the frame's render targets, read by later passes (changes with the size).
#define MYRIAD_SET_TARGETS 1
#define MYRIAD_BINDING_GBUFFER_DEPTH 0
#define MYRIAD_BINDING_GBUFFER_NORMAL 1
#define MYRIAD_BINDING_GBUFFER_BASE_COLOR 2
#define MYRIAD_BINDING_GBUFFER_MATERIAL 3
#define MYRIAD_BINDING_GBUFFER_UV 4
#define MYRIAD_BINDING_HDR 5
#define MYRIAD_BINDING_LIGHT_COUNT 6          // sampled: lights that shaded each pixel (R32F)
#define MYRIAD_BINDING_HDR_STORAGE 7          // storage image: compute lighting writes HDR here
#define MYRIAD_BINDING_LIGHT_COUNT_STORAGE 8  // storage image: compute lighting writes counts here
#define MYRIAD_BINDING_GBUFFER_EMISSIVE 9     // sampled: emitted radiance (RGBA16F, a unused)
#define MYRIAD_BINDING_MARKER_KEYS 10         // storage image: light markers' keys (shaders/markers.h)
#define MYRIAD_BINDING_OUTPUT 11              // storage image: the output (RGBA8, or RGBA32F when raw)
#define MYRIAD_BINDING_LDR 12                 // sampled (linear filter): tonemapped final + luma, for AA
#define MYRIAD_BINDING_LDR_STORAGE 13         // storage image: the same, written by the final pass
#define MYRIAD_BINDING_EDGE_PIXELS 14         // storage buffer: AntialiasEdges, then the edge pixels
#define MYRIAD_BINDING_YUV_PLANES 15          // storage buffer: final as YCbCr 4:2:0 planes (yuv420.comp)
#define MYRIAD_BINDING_CLUSTER_MARKS 16       // storage buffer: a bit per cluster, set where it holds
                                              // visible geometry (clustered; FrameTargets)
#define MYRIAD_BINDING_GBUFFER_LAYERS 17      // sampled: clear coat and sheen (RG32UI: two
                                              // packUnorm4x8 words, material_core.glsl)

// The G-buffer rasterised in compute (render/visibility.h; shaders/visibility.glsl): its pipelines'
// set 1 (their layout is set 0 = the scene, set 1 = this; not the frame's targets set).
#define MYRIAD_SET_VISIBILITY 1
#define MYRIAD_BINDING_VISIBILITY_VERTICES 0   // storage float[]: the scene's vertices (scene::Vertex)
#define MYRIAD_BINDING_VISIBILITY_INDICES 1    // storage uint[]: the scene's indices
#define MYRIAD_BINDING_VISIBILITY_DRAWS 2      // storage uvec4[]: header, then one per draw
#define MYRIAD_BINDING_VISIBILITY_KEYS 3       // storage uint64[] per pixel: depth bits << 32 | triangle
#define MYRIAD_BINDING_VISIBILITY_DEPTH 4      // storage float[] per pixel: copied into the depth target
#define MYRIAD_BINDING_VISIBILITY_LARGE 5      // storage: VisibilityLargeHeader, then VisibilityTriangle[]
#define MYRIAD_BINDING_VISIBILITY_NORMAL 6     // storage images: the G-buffer targets (GENERAL)
#define MYRIAD_BINDING_VISIBILITY_BASE_COLOR 7 // (an RGBA8_UNORM view: the shader encodes sRGB)
#define MYRIAD_BINDING_VISIBILITY_MATERIAL 8
#define MYRIAD_BINDING_VISIBILITY_UV 9
#define MYRIAD_BINDING_VISIBILITY_EMISSIVE 10
#define MYRIAD_BINDING_VISIBILITY_CLUSTER_MARKS 11  // storage uint[]: FrameTargets::clusterMarks
#define MYRIAD_VISIBILITY_BINDINGS 12
#define MYRIAD_VISIBILITY_NONE 0xFFFFFFFFu       // a pixel's triangle where none was drawn
#define MYRIAD_VISIBILITY_GROUP 64               // triangles per workgroup of the visibility pass
#define MYRIAD_VISIBILITY_SUBPIXEL_BITS 8        // vertices snap to 1/256 pixel, as raster units do
// A triangle whose box holds more pixel centres than this is queued for the tile pass (a
// workgroup per 64x64 tile it touches) instead of being walked by its one thread.
#define MYRIAD_VISIBILITY_SMALL_PIXELS 256
#define MYRIAD_VISIBILITY_TILE 64                // pixels across a tile of the tile pass
#define MYRIAD_VISIBILITY_TILE_THREADS 16        // its workgroup: 16x16, each thread 4x4 pixels
#define MYRIAD_VISIBILITY_LARGE_CAPACITY 65535u  // queued triangles (an indirect dispatch's z)
// Clipping keeps projected vertices within this many viewports of the centre, so fixed-point
// edge functions of 8192-pixel frames stay far inside 64-bit integers.
#define MYRIAD_VISIBILITY_GUARD_BAND 16.0

// Skinning and morphing (render/skinning.h, shaders/skinning.comp): the pre-pass's own set 0.
// The posed vertices live in the scene's vertex buffer after its meshes, one region per posed
// instance, so every pass that reads vertices reads them by the draw's vertexOffset alone.
#define MYRIAD_SKIN_BINDING_VERTICES 0    // storage float[]: the scene's vertices (scene::Vertex,
                                          // 16 floats), read (rest) and written (posed regions)
#define MYRIAD_SKIN_BINDING_INFLUENCES 1  // storage uvec4[]: per skinned rest vertex its joints,
                                          // then its weights (float bits)
#define MYRIAD_SKIN_BINDING_MORPHS 2      // storage float[]: morph displacements, 3 floats a vertex
#define MYRIAD_SKIN_BINDING_TARGETS 3     // storage uvec4[]: per morph target where its positions,
                                          // normals, tangents start in MORPHS (NONE: not moved)
#define MYRIAD_SKIN_BINDING_JOBS 4        // storage SkinJob[]: one per posed instance
#define MYRIAD_SKIN_BINDING_POSE 5        // storage vec4[]: joint matrices (3 rows each), weights
#define MYRIAD_SKIN_BINDING_PREVIOUS 6    // storage vec4[]: previous-time positions (motion)
#define MYRIAD_SKIN_BINDINGS 7
#define MYRIAD_SKIN_GROUP 64              // vertices per workgroup
#define MYRIAD_SKIN_NONE 0xFFFFFFFFu
#define MYRIAD_VERTEX_FLOATS 16           // scene::Vertex: position 0, normal 3, uv 6, tangent 8, colour 12

// One posed instance's work: its mesh's rest vertices deformed into its region.
MYRIAD_STRUCT(SkinJob) {
  uvec4 vertices;  // x first rest vertex, y vertex count, z first posed vertex (both in the
                   // scene's vertex buffer), w first previous position (MYRIAD_SKIN_BINDING_PREVIOUS)
  uvec4 skin;      // x first influence pair (NONE: not skinned), y first joint row (vec4 index
                   // into POSE), z joint count, w unused
  uvec4 morph;     // x first target (TARGETS), y target count, z first weight (float index into
                   // POSE), w unused
};
// The pre-pass's push constant: x 0 = write posed vertices, 1 = previous positions only; y the
// first job of the dispatch (workgroup y counts from it).
MYRIAD_STRUCT(SkinPush) {
  uvec4 mode;
};

// The motion pass (render/motion.h, shaders/motion.vert): its own set 1 beside the scene's set 0.
#define MYRIAD_SET_MOTION 1
#define MYRIAD_MOTION_BINDING_INSTANCES 0  // storage GpuInstance[]: the previous time's placements
#define MYRIAD_MOTION_BINDING_VERTICES 1   // storage uvec4[] per instance: x first previous
                                           // position (NONE: the vertex did not deform), y its
                                           // first posed vertex
#define MYRIAD_MOTION_BINDING_PREVIOUS 2   // storage vec4[]: previous-time positions (asset space)
#define MYRIAD_MOTION_BINDINGS 3
MYRIAD_STRUCT(MotionPush) {
  mat4 previousViewProjection;
  uvec4 flags;  // x 1: per-instance vertex records are bound (posed scene); y 1: raw output
};

// Temporal anti-aliasing of a stream's frames (render/temporal.h, shaders/temporal_resolve.comp):
// its own set 0 and push constant; the frame's sets are bound again after it.
#define MYRIAD_TEMPORAL_BINDING_CURRENT 0        // sampler2D: the frame as the final pass left it
                                                 // (copied into an RGBA8 sRGB image: linear reads)
#define MYRIAD_TEMPORAL_BINDING_DEPTH 1          // sampler2D: the frame's depth (nearest)
#define MYRIAD_TEMPORAL_BINDING_HISTORY 2        // sampler2D (linear): the history's YCoCg + count
#define MYRIAD_TEMPORAL_BINDING_HISTORY_DEPTH 3  // sampler2D: the history's view depth (nearest)
#define MYRIAD_TEMPORAL_BINDING_NEXT 4           // storage rgba16f: the new history (written)
#define MYRIAD_TEMPORAL_BINDING_NEXT_DEPTH 5     // storage r32f: its view depth (written)
#define MYRIAD_TEMPORAL_BINDING_OUTPUT 6         // storage rgba8: the frame's output (written)
#define MYRIAD_TEMPORAL_BINDINGS 7
MYRIAD_STRUCT(TemporalPush) {
  // Unjittered NDC of this frame (x, y, depth, 1) -> the previous frame's clip position divided
  // by this frame's view depth: previous viewProjection x inverse(this viewProjection).
  mat4 reprojection;
  vec4 jitter;  // xy: this frame's jitter in pixels (FrameSettings::jitter); zw: 1 / size
  // x near, y far plane (this camera's: its view depth from the depth buffer); z 1 where the
  // history holds an earlier frame, else 0; w the blend's least weight of the current frame.
  vec4 params;
  // x: the relative view-depth difference past which the history is a disocclusion; yzw unused.
  vec4 limits;
};

// Descriptor set 2: light culling. Each compute technique binds its own set of this layout
// (server/render/techniques/) and writes the bindings its shaders use.
#define MYRIAD_SET_CULLING 2
#define MYRIAD_BINDING_CLUSTER_RANGES 0    // uvec2 per cluster: first index, light count
#define MYRIAD_BINDING_CLUSTER_LIGHTS 1    // uint light indices, every cluster's list back to back
#define MYRIAD_BINDING_CULLING_STATS 2     // CullingStats, read back after the frame
#define MYRIAD_BINDING_CLUSTER_CURSORS 3   // uint per cluster: recorded pairs (count, then fill
                                           // cursor), then a uint per cluster: pairs not recorded
#define MYRIAD_BINDING_LARGE_LIGHTS 4      // LargeLightQueue, then the queued light indices
#define MYRIAD_BINDING_CLUSTER_PAIRS 5     // uint[]: recorded light-cluster pairs (cluster_assign_binned.comp)

// Descriptor set 3: one material's textures (the G-buffer pass binds one set per material; lavapipe
// has no descriptor indexing). A slot the material lacks holds a 1x1 white image, and the
// material's flags say which are real.
#define MYRIAD_SET_MATERIAL 3
#define MYRIAD_BINDING_TEXTURE_BASE_COLOR 0          // sRGB view
#define MYRIAD_BINDING_TEXTURE_METALLIC_ROUGHNESS 1  // UNORM view: B metallic, G roughness
#define MYRIAD_BINDING_TEXTURE_NORMAL 2              // UNORM view: tangent space
#define MYRIAD_BINDING_TEXTURE_OCCLUSION 3           // UNORM view: R
#define MYRIAD_BINDING_TEXTURE_EMISSIVE 4            // sRGB view
#define MYRIAD_TEXTURE_SLOTS 5

// GpuMaterial.flags.x bits: bit i (i < MYRIAD_TEXTURE_SLOTS) the material has texture slot i.
#define MYRIAD_MATERIAL_ALPHA_MASK 0x100u    // alphaMode MASK: fragments below the cutoff dropped
#define MYRIAD_MATERIAL_ALPHA_BLEND 0x200u   // alphaMode BLEND
#define MYRIAD_MATERIAL_DOUBLE_SIDED 0x400u  // back faces drawn, their normal flipped
#define MYRIAD_MATERIAL_UNLIT 0x800u         // KHR_materials_unlit: emits its base colour, reflects nothing

// Tiled: 16x16-pixel tiles, one workgroup each; a tile's list lives in shared memory.
#define MYRIAD_TILE_SIZE 16
#define MYRIAD_TILE_MAX_LIGHTS 2048

// Clustered: 64x64-pixel screen tiles x exponential depth slices between near and far.
#define MYRIAD_CLUSTER_TILE_SIZE 64
#define MYRIAD_CLUSTER_SLICES 32
#define MYRIAD_CLUSTER_INACTIVE 0xFFFFFFFFu  // cursor value of a cluster no pixel falls in
// The clustered shading pass narrows its clusters' lists per MYRIAD_CLUSTER_SHADE_TILE-square
// tile (one workgroup; divides MYRIAD_CLUSTER_TILE_SIZE) into shared memory: at most this many
// references per tile (all its slices together), at most this many slices from its nearest;
// pixels beyond either walk their cluster's whole list.
#define MYRIAD_CLUSTER_SHADE_TILE 16
#define MYRIAD_CLUSTER_TILE_LIGHTS 2048
// How light_clustered_subgroup.comp walks, bits of its specialisation constant
// MYRIAD_SPEC_SHADE_VARIANT (techniques/clustered.cpp sets MYRIAD_SHADE_DEFAULT unless the
// benchmark's --tune shade-variant asks for others, render/tuning.h; bench/history/).
#define MYRIAD_SPEC_SHADE_VARIANT 9               // constant_id
#define MYRIAD_SHADE_MASK_WALK 0x1u              // every pixel shades its own mask of a chunk's lights
#define MYRIAD_SHADE_BOX_ALWAYS 0x2u             // the mask walk tests the subgroup's box on every segment
#define MYRIAD_SHADE_NARROW_WORLD 0x8u           // the narrowing: the world bounds of the slice's points
#define MYRIAD_SHADE_HYBRID 0x20u                // mask walk: lights holding the subgroup's box walked together
#define MYRIAD_SHADE_SHORT_64 0x10u              // mask walk: segments of <= 64 lights walked per pixel
#define MYRIAD_SHADE_DIAG_NARROW_ONLY 0x100u     // a measurement: narrowing only (image wrong)
#define MYRIAD_SHADE_DIAG_NO_BRDF 0x200u         // a measurement: walks and reach tests, no BRDF (image wrong)
#define MYRIAD_SHADE_DIAG_NO_SHORT 0x1000u       // a measurement: segments walked per pixel only counted (image wrong)
#define MYRIAD_SHADE_DIAG_NO_TOGETHER 0x2000u    // a measurement: lights holding the box only counted (image wrong)
#define MYRIAD_SHADE_DIAG_NO_APART 0x4000u       // a measurement: the other lights only counted (image wrong)
#define MYRIAD_SHADE_DIAG_NO_NEAR 0x8000u        // a measurement: their near masks made, not shaded (image wrong)
#define MYRIAD_SHADE_KEYS 0x40u                  // the subgroups' point bounds reduced as ordered words, not floats
#define MYRIAD_SHADE_DEFAULT 0x7Bu  // mask walk, box always, world narrowing, hybrid, short per pixel, keys
// Lights whose box spans more clusters than this are assigned by a workgroup each, not a thread;
// the indirect dispatch doing it has at most this many groups (Vulkan's guaranteed minimum).
#define MYRIAD_LARGE_LIGHT_CLUSTERS 64
#define MYRIAD_LARGE_LIGHT_GROUPS 65535u
#define MYRIAD_CLUSTER_TILE_SLICES 8
// The small lights' assignment (cluster_assign_binned.comp) counts a workgroup's light-cluster
// pairs in a shared table of this many clusters, indexed by their number among the frame's active
// clusters; clusters numbered past it take a global atomic per pair.
#define MYRIAD_ASSIGN_BINS 4096u

// Workgroup sizes. The shaders' local_size and the C++ dispatch counts both use these macros, so
// they cannot disagree; Pipelines checks at start-up that the device runs groups this large
// (Vulkan guarantees only 128 invocations; lavapipe and desktop GPUs give 1024).
#define MYRIAD_LIGHTS_PER_GROUP 64
#define MYRIAD_PIXEL_GROUP 8
// The final pass on CPU devices (final_cpu.comp): 16x16 pixels share an 18x18 tile, 1.27 colour
// encodings a pixel instead of 1.56 with 8x8 (10x10 tiles).
#define MYRIAD_FINAL_CPU_GROUP 16
// What final_cpu.comp does, bits of its specialisation constant MYRIAD_SPEC_FINAL_PARTS (one
// pipeline per combination a frame asks for, render/passes.cpp): llvmpipe executes both sides of
// every branch, so the marker resolve and the anti-aliasing tile cost every pixel of a frame that
// has them off unless they are compiled out. GPUs keep one pipeline that tests the uniforms.
#define MYRIAD_SPEC_FINAL_PARTS 10  // constant_id
// views_pass.glsl's kShadowView (constant_id): 1 in the pipelines of the `shadow` view alone
// (Pipelines::viewsFor), 0 in the others, which so leave its code out.
#define MYRIAD_SPEC_SHADOW_VIEW 11
#define MYRIAD_FINAL_ANTIALIAS 0x1u
#define MYRIAD_FINAL_MARKERS 0x2u
#define MYRIAD_SCAN_GROUP 256
// One cluster a scan thread: more, smaller workgroups (64 at 1080p) finish sooner than 4 a thread
// (H200, issue 16 stop 17: the scan 0.0077 -> 0.0059 ms at 1080p, 0.0077 -> 0.0060 at 4K).
#define MYRIAD_SCAN_CLUSTERS_PER_THREAD 1
// The binned assignment's least workgroup size (cluster_assign_binned.comp's default); the
// clustered technique runs it larger where the device allows (techniques/clustered.cpp).
#define MYRIAD_ASSIGN_BIN_GROUP 256

// The view the tonemap pass writes (FrameUniforms.flags.x). render::Target's values
// (render/gpu_types.h checks them).
#define MYRIAD_VIEW_FINAL 0
#define MYRIAD_VIEW_ALBEDO 1
#define MYRIAD_VIEW_NORMAL 2
#define MYRIAD_VIEW_POSITION 3
#define MYRIAD_VIEW_UV 4
#define MYRIAD_VIEW_METALLIC 5
#define MYRIAD_VIEW_ROUGHNESS 6
#define MYRIAD_VIEW_DEPTH 7
#define MYRIAD_VIEW_LIGHT_VOLUMES 8
#define MYRIAD_VIEW_LIGHT_COUNT 9
#define MYRIAD_VIEW_CLUSTERS 10
#define MYRIAD_VIEW_EMISSIVE 11
#define MYRIAD_VIEW_OCCLUSION 12
// 13-16 are the label and motion targets, drawn by their own passes.
#define MYRIAD_VIEW_SHADOW 17  // the sun's shadow factor, tinted by cascade (views_pass.glsl)

// Anti-aliasing of `final` (FrameUniforms.post.x): render::Antialias's values (gpu_types.h checks).
#define MYRIAD_ANTIALIAS_NONE 0
#define MYRIAD_ANTIALIAS_FXAA 1

// The G-buffer targets a frame writes only when it needs them (FrameUniforms.written.x): the uv
// target for the uv view, emission when a material emits or for the emissive view, the layers
// when a material has a clear coat or a sheen. Raster output
// is what the G-buffer pass spends its time on where few units rasterize (docs/performance.md).
#define MYRIAD_GBUFFER_UV 1u
#define MYRIAD_GBUFFER_EMISSIVE 2u
#define MYRIAD_GBUFFER_LAYERS 4u  // clear coat and sheen: when a material of the scene has either

// What the compute G-buffer's resolve adds for the clustered technique (FrameUniforms.written.z,
// bits; MYRIAD_BINDING_CLUSTER_MARKS): MARKS, the bit of each cluster holding geometry; BOUNDS,
// the world bounds of each cluster's surface points too, where the light test reads them
// (cluster_assign.glsl's kPointTest other than 0; CPU devices default to 0 and gather none).
#define MYRIAD_RESOLVE_MARKS 1u
#define MYRIAD_RESOLVE_BOUNDS 2u

// What a pixel's shading may need this frame, as bits of the specialisation constant
// MYRIAD_SPEC_SHADING_FEATURES (frame.glsl's kShadingFeatures; render/shading_features.h sets it
// for the compute lighting passes). A pipeline specialised without a bit has that feature's code
// compiled out; the frame's uniforms still decide where a feature is on. Unspecialised pipelines
// keep every bit. llvmpipe runs both sides of every branch a pixel could take, so on the CPU path
// code behind a condition that is false all frame still costs its full price.
#define MYRIAD_SPEC_SHADING_FEATURES 8  // constant_id (the cluster assignment shaders use 0-3)
#define MYRIAD_FEATURE_ENVIRONMENT 0x1u     // environment light and background (mode not none)
#define MYRIAD_FEATURE_SUN_SHADOW 0x2u      // the sun's shadow map
#define MYRIAD_FEATURE_EXTRA_SUNS 0x4u      // a model's directional lights besides the sun
#define MYRIAD_FEATURE_EMISSIVE 0x8u        // the emissive G-buffer target (MYRIAD_GBUFFER_EMISSIVE)
#define MYRIAD_FEATURE_SPOT_LIGHTS 0x10u    // a light with a cone (cone.z > MYRIAD_POINT_LIGHT_COS_OUTER)
#define MYRIAD_FEATURE_WINDOW_FALLOFF 0x20u // a light with the window falloff (radianceFalloff.w >= 0)
#define MYRIAD_FEATURE_INVERSE_SQUARE 0x40u // a light with inverse-square falloff
#define MYRIAD_FEATURE_LOCAL_SHADOWS 0x80u  // shadowed local lights (FrameUniforms.lightShadows.x)
#define MYRIAD_FEATURE_LAYERS 0x100u        // clear coat and sheen (MYRIAD_GBUFFER_LAYERS)
#define MYRIAD_FEATURES_ALL 0x1FFu

// Directional lights besides the sun (scene::kMaxExtraSuns; render/gpu_types.h checks it).
#define MYRIAD_MAX_EXTRA_SUNS 3

// One shadowed local light's map (FrameUniforms.lightShadow). Depth in its tiles is perspective
// depth between near and far along the tile's axis: far / (far - near) * (1 - near / d).
MYRIAD_STRUCT(GpuLightShadow) {
  mat4 mapFromWorld;   // spot: world -> the tile's clip space (w = distance along the axis)
  vec4 positionNear;   // xyz where the map was rendered from, w near (world units)
  vec4 params;         // x far (the light's radius), y one texel's width per unit of distance,
                       // zw unused
  uvec4 tiles;         // x first tile in the atlas, y MYRIAD_LIGHT_SHADOW_SPOT / _CUBE, zw unused
};

MYRIAD_STRUCT(FrameUniforms) {
  mat4 view;
  mat4 projection;
  mat4 viewProjection;
  mat4 inverseViewProjection;
  vec4 cameraPosition;   // xyz world position, w unused
  vec4 sunDirection;     // xyz unit vector pointing towards the sun, w = intensity
  vec4 sunColor;         // rgb linear, w unused
  vec4 ambient;          // rgb ambient radiance, w unused
  vec4 background;       // rgb radiance where no geometry was drawn, w unused
  vec4 viewport;         // width, height, 1/width, 1/height
  vec4 camera;           // x exposure, y near, z far, w unused
  vec4 boundsMin;        // scene bounds, for the position view; w unused
  vec4 boundsMax;
  uvec4 flags;           // x view (MYRIAD_VIEW_*), y light count, z raw output (0/1), w list capacity
  uvec4 grid;            // x,y clusters across/down, z depth slices, w technique (render::Technique)
  uvec4 written;         // x the optional G-buffer targets this frame wrote (MYRIAD_GBUFFER_*);
                         // y the cluster grid's tile size in pixels (render/cluster_grid.h);
                         // z what the compute G-buffer's resolve does for the clustered technique
                         // (MYRIAD_RESOLVE_*; 0 where another technique lights the frame);
                         // w unused
  vec4 slicing;          // x slices / ln(far/near), y ln(near) * x, z heat-map max, w time (s)
  vec4 environment;      // x mode (MYRIAD_ENV_*), y intensity, z background shown (0/1), w unused
  vec4 environmentRotation;  // x cos, y sin of the environment's rotation about +Y
  uvec4 post;            // x anti-aliasing of this frame (MYRIAD_ANTIALIAS_*: NONE unless the view
                         // is an 8-bit final), y light markers drawn (0/1), zw unused
  // Directional lights besides the sun (a model's): xyz towards the light, w intensity (0: none).
  vec4 extraSunDirection[MYRIAD_MAX_EXTRA_SUNS];
  vec4 extraSunColor[MYRIAD_MAX_EXTRA_SUNS];  // rgb linear, w unused
  // The sun's shadow cascades (render/shadows.h): world -> (u, v, depth) of cascade c's map
  // (orthographic, so w = 1), u and v in [0, 1] across the cascade's own tile of the atlas.
  mat4 sunShadowMatrix[MYRIAD_MAX_SUN_CASCADES];
  vec4 sunShadow;  // x cascades (0: the sun casts no shadows), y a tile's size (texels), z and w
                   // the atlas's columns and rows of tiles
  // Per cascade: x one texel in world units (the normal offset), y one texel of depth in map
  // depth units (the bias), z the cascade's far end (view depth; the last reaches past the
  // scene), w 1 for the frame's cascades, 0 past them (frame.glsl's loops read this, not
  // sunShadow.x: sunShadowCascade says why).
  vec4 sunCascade[MYRIAD_MAX_SUN_CASCADES];
  // Local lights' shadows (render/shadows.cpp). x how many lights have a map this frame (0: none,
  // and no shader reads further), y tile size (texels), zw the atlas's size (texels).
  uvec4 lightShadows;
  // The shadowed lights' indices into the light buffer, four per uvec4 (slot i: [i / 4][i % 4]).
  uvec4 shadowedLightIndex[MYRIAD_MAX_SHADOWED_LIGHTS / 4];
  GpuLightShadow lightShadow[MYRIAD_MAX_SHADOWED_LIGHTS];
  // Stochastic local shadows (render/stochastic_shadows.h): x the frame's random seed, y the
  // candidates a pixel draws (tuning), z MYRIAD_STOCHASTIC_* bits (0: off), w the shadow ray's
  // offset off the surface (float bits, world units).
  uvec4 stochastic;
  // Distance fog (settings fog; render/frame_passes/fog.cpp): rgb the fog's colour (linear), w
  // its density per metre (0: off, and no pass reads it).
  vec4 fog;
};
#define MYRIAD_STOCHASTIC_ON 1u
#define MYRIAD_STOCHASTIC_TRACE_SUN 2u  // the sun casts shadows: traced too (no map is drawn)

// The shadow pass's push constant: world -> the light's clip space.
MYRIAD_STRUCT(ShadowPush) {
  mat4 viewProjection;
};

// Push constants of the environment's compute passes (render/environment.cpp).
MYRIAD_STRUCT(EnvironmentParams) {
  vec4 sunDirection;  // xyz towards the sun (unit), w unused
  vec4 sunColor;      // rgb linear, w unused
  uvec4 step;         // x pyramid level written (downsample), y mode; zw unused
};

// The clustered assignment's queue of large lights: an indirect dispatch's group counts, then the
// queue's length; the light indices follow in the same buffer.
MYRIAD_STRUCT(LargeLightQueue) {
  uvec4 groups;  // VkDispatchIndirectCommand x, y, z; w unused
  uvec4 queued;  // x lights queued; yzw unused
};

// The pixels the final pass found on an edge (anti-aliasing on): an indirect dispatch's group
// counts (MYRIAD_EDGES_PER_GROUP pixels a group), then the list's length; the pixels follow in the
// same buffer, each as x | y << 16. The anti-aliasing pass filters only these.
MYRIAD_STRUCT(AntialiasEdges) {
  uvec4 groups;  // VkDispatchIndirectCommand x, y, z; w unused
  uvec4 count;   // x pixels listed; yzw unused
};
#define MYRIAD_EDGES_PER_GROUP 64

// The tile pass's queue (MYRIAD_BINDING_VISIBILITY_LARGE): an indirect dispatch's group counts
// (tiles across, tiles down, queued triangles), then the capacity.
MYRIAD_STRUCT(VisibilityLargeHeader) {
  uvec4 groups;  // VkDispatchIndirectCommand x, y, z; w MYRIAD_VISIBILITY_LARGE_CAPACITY
};
// One queued triangle (after clipping): vertices in fixed point (MYRIAD_VISIBILITY_SUBPIXEL_BITS),
// wound so that its edge functions are positive inside; depth as float bits.
MYRIAD_STRUCT(VisibilityTriangle) {
  uvec4 xy01;      // x0, y0, x1, y1 (int bits)
  uvec4 xy2Depth;  // x2, y2 (int bits), z0, z1 (float bits)
  uvec4 depthId;   // z2 (float bits), triangle id, yz unused
  uvec4 pixels;    // the pixel centres' box: min x, min y, max x, max y (inclusive)
};

// Counters the culling passes write and the host reads back: nothing is dropped silently.
MYRIAD_STRUCT(CullingStats) {
  uvec4 overflow;  // x tiles that overflowed, y light indices dropped (tiles), z light indices
                   // dropped (clusters), w unused
  uvec4 totals;    // x light indices written (clusters), y active clusters, z most lights in a
                   // tile or cluster, w list slots handed out (clusters; the scan's running total)
};

// A local light, point or spot (48 bytes: a million fit in 48 MB). radiance = color * intensity.
// The light reaches a point closer than the radius and inside the cone (cos of the angle from the
// spot direction > cone.z); a point light has cone.z = -2, so every direction is inside.
MYRIAD_STRUCT(GpuPointLight) {
  vec4 positionRadius;   // xyz world position, w radius (the light is exactly 0 from here on)
  vec4 radianceFalloff;  // rgb radiance, w attenuation: >= 0 the window's constant C,
                         // MYRIAD_ATTENUATION_INVERSE_SQUARE (< 0) inverse-square
  vec4 cone;             // xy spot direction (octahedral, shading.glsl), z cos(outer angle),
                         // w cos(inner angle)
};
#define MYRIAD_ATTENUATION_INVERSE_SQUARE (-1.0f)
#define MYRIAD_POINT_LIGHT_COS_OUTER (-2.0f)
#define MYRIAD_POINT_LIGHT_COS_INNER (-1.0f)

MYRIAD_STRUCT(GpuInstance) {
  mat4 model;
  mat4 normalMatrix;     // inverse-transpose of model (upper 3x3 used)
  uvec4 material;        // x material index, y its object (instance-id label; 0 none), z the
                         // object's semantic class (semantic-id label)
};

MYRIAD_STRUCT(GpuMaterial) {
  vec4 baseColor;          // linear rgb, a alpha factor
  vec4 metallicRoughness;  // x metallic, y perceptual roughness, z normal scale, w occlusion strength
  vec4 emissive;           // rgb emissive factor x emissive strength, w alpha cutoff
  uvec4 flags;             // x MYRIAD_MATERIAL_* and texture-slot bits, y the dielectric's F0
                           // (float bits: KHR_materials_ior x _specular), z its F90 (float bits:
                           // KHR_materials_specular's factor)
  // Per texture slot, two rows of the 2x3 KHR_texture_transform matrix: uv' = M * (uv, 1).
  vec4 uvTransform[2 * MYRIAD_TEXTURE_SLOTS];
  vec4 layers;             // x KHR_materials_clearcoat's factor, y its roughness, z
                           // KHR_materials_sheen's roughness, w unused
  vec4 sheenColor;         // rgb KHR_materials_sheen's colour (0: no sheen), w unused
};
#define MYRIAD_MATERIAL_TEXELS (6 + 2 * MYRIAD_TEXTURE_SLOTS)  // texels of one GpuMaterial

#ifdef __cplusplus
}  // namespace myriad::gpu_types
#endif
#endif
