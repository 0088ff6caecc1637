// The sun's cascades recorded: drawn whole (ShadowMaps::recordSun), repaired under moved objects
// (repairSun), scrolled after a camera move (scrollSun), or kept (sunHolds). render/shadows.h
// says what each does; render/shadows.cpp makes the maps.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_access.hpp>

#include "gpu/commands.h"
#include "render/raster.h"
#include "render/shadow_recording.h"
#include "render/shadows.h"
#include "shared_types.h"

namespace myriad::render {

using namespace shadow_recording;

namespace {

// The texels of a `size`-wide map under world-space spheres (centre, radius) seen through the
// orthographic `viewProjection`, grown by two texels (rasterisation rounding): x0, y0, x1, y1.
struct TexelsUnder {
  glm::mat4 viewProjection;
  glm::vec2 scale;  // clip units per world unit across x and y
  float texels;
  TexelsUnder(const glm::mat4& vp, uint32_t size)
      : viewProjection(vp),
        // An orthographic map: a world length along a row of the matrix scales by that row's length.
        scale(glm::length(glm::vec3(glm::row(vp, 0))), glm::length(glm::vec3(glm::row(vp, 1)))),
        texels(float(size)) {}
  glm::ivec4 operator()(glm::vec4 sphere) const {
    const glm::vec4 clip = viewProjection * glm::vec4(glm::vec3(sphere), 1.0f);
    const glm::vec2 reach = sphere.w * scale;
    const glm::vec2 lo = (glm::vec2(clip) - reach) * 0.5f + 0.5f;
    const glm::vec2 hi = (glm::vec2(clip) + reach) * 0.5f + 0.5f;
    return {int(std::floor(lo.x * texels)) - 2, int(std::floor(lo.y * texels)) - 2,
            int(std::ceil(hi.x * texels)) + 2, int(std::ceil(hi.y * texels)) + 2};
  }
};

bool overlaps(const glm::ivec4& a, const glm::ivec4& b) {
  return a.x < b.z && b.x < a.z && a.y < b.w && b.y < a.w;
}

// Most moved spheres a repair takes, and the largest share of a cascade's map it redraws: past
// either, drawing the maps whole costs about the same.
constexpr size_t kMaxRepairSpheres = 256;
constexpr double kMaxRepairShare = 0.25;
// The largest share of the maps a scroll draws again (the strips a camera move uncovered): past
// it, drawing them whole costs about the same as the copies and strips.
constexpr double kMaxScrollShare = 0.5;

// How far cascade `c`'s map moved from `before` to `after` (its world -> clip transforms), in
// whole texels of its `size`-texel tile (+x right, +y down): a world point's texel u becomes
// u + shift. Only when the two differ by that alone (the same sun, texel size and depth range:
// fitSunCascades then changes the translation only); nullopt otherwise.
std::optional<glm::ivec2> texelShift(const glm::mat4& before, const glm::mat4& after,
                                     uint32_t size) {
  for (int column = 0; column < 4; ++column) {
    for (int row = 0; row < 4; ++row) {
      const bool translation = column == 3 && row < 2;
      if (!translation && before[column][row] != after[column][row]) return std::nullopt;
    }
  }
  // Clip x and y run -1..1 across the tile: a clip offset of t is t * size / 2 texels.
  const glm::vec2 shift = (glm::vec2(after[3][0], after[3][1]) -
                           glm::vec2(before[3][0], before[3][1])) * (0.5f * float(size));
  const glm::vec2 whole = glm::round(shift);
  if (std::abs(shift.x - whole.x) > 0.01f || std::abs(shift.y - whole.y) > 0.01f) return std::nullopt;
  return glm::ivec2(whole);
}

// Points cascade `c`'s drawing at its tile of the atlas (viewport; `rect`, in the tile's texels,
// the scissor) with its view-projection pushed.
void beginCascade(VkCommandBuffer cmd, const Pipelines& p, const SunShadowFit& fit, uint32_t c,
                  const glm::ivec4& rect) {
  const glm::uvec2 grid = sunAtlasGrid(fit.cascades);
  const int x = int((c % grid.x) * fit.tileSize);
  const int y = int((c / grid.x) * fit.tileSize);
  const float size = float(fit.tileSize);
  const VkViewport viewport{float(x), float(y), size, size, 0.0f, 1.0f};
  const VkRect2D scissor{{x + rect.x, y + rect.y},
                         {uint32_t(rect.z - rect.x), uint32_t(rect.w - rect.y)}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  gpu_types::ShadowPush push{fit.viewProjection[c]};
  vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
}

// Every caster whose sphere reaches into `rect` (texels) of cascade `c`'s map.
void drawCastersInto(VkCommandBuffer cmd, const SceneBuffers& scene, const SunShadowFit& fit,
                     uint32_t c, const glm::ivec4& rect) {
  const TexelsUnder under(fit.viewProjection[c], fit.tileSize);
  InstancedDraws draws(cmd);
  for (const DrawItem& draw : scene.draws) {
    if (overlaps(rect, under(glm::vec4(draw.centre, draw.radius)))) draws.add(draw.mesh, draw.instance);
  }
}

// Clears `rect` (texels) of cascade `c`'s tile and draws into it again: the casters reaching in,
// clipped to it (a repair's or a scroll's part of the maps; a rendering with the atlas loaded is
// open).
void redrawRect(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                const SunShadowFit& fit, uint32_t c, const glm::ivec4& rect) {
  const glm::uvec2 grid = sunAtlasGrid(fit.cascades);
  const int x = int((c % grid.x) * fit.tileSize);
  const int y = int((c / grid.x) * fit.tileSize);
  VkClearAttachment clear{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
  clear.clearValue.depthStencil = {1.0f, 0};
  const VkClearRect clearRect{
      {{x + rect.x, y + rect.y}, {uint32_t(rect.z - rect.x), uint32_t(rect.w - rect.y)}}, 0, 1};
  vkCmdClearAttachments(cmd, 1, &clear, 1, &clearRect);
  beginCascade(cmd, p, fit, c, rect);
  drawCastersInto(cmd, scene, fit, c, rect);
}

}  // namespace

// One rendering over the whole atlas (cleared once), a viewport per cascade: a cascade's clip
// space maps onto its own tile, and clipping keeps every draw inside it.
void ShadowMaps::recordSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                           const SunShadowFit& fit) {
  beginShadowRendering(cmd, p, scene, sun_);
  const glm::ivec4 whole{0, 0, int(fit.tileSize), int(fit.tileSize)};
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    beginCascade(cmd, p, fit, c, whole);
    if (fit.cascades == 1) {
      drawCasters(cmd, scene);  // the map holds the whole scene
    } else {
      drawCastersInto(cmd, scene, fit, c, whole);
    }
  }
  endShadowRendering(cmd, sun_);
  sunReadable_ = true;
  sunScene_ = scene.generation;
  sunFit_ = fit;
}

bool ShadowMaps::repairSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                           const SunShadowFit& fit) {
  if (!sunReadable_ || sunScene_ == 0 || !sunFit_.sameMaps(fit)) return false;
  const std::optional<std::vector<glm::vec4>> moved =
      scene.movedSince(sunScene_, kMaxRepairSpheres);
  if (!moved) return false;
  const uint32_t size = fit.tileSize;
  const int limit = int(size);
  std::array<glm::ivec4, kMaxSunCascades> rects{};
  bool any = false;
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    glm::ivec4 rect{limit, limit, 0, 0};
    const TexelsUnder texelsUnder(fit.viewProjection[c], size);
    for (const glm::vec4& sphere : *moved) {
      const glm::ivec4 under = texelsUnder(sphere);
      rect = {std::min(rect.x, under.x), std::min(rect.y, under.y), std::max(rect.z, under.z),
              std::max(rect.w, under.w)};
    }
    rects[c] = glm::clamp(rect, glm::ivec4(0), glm::ivec4(limit));
    const glm::ivec4& r = rects[c];
    if (r.x >= r.z || r.y >= r.w) continue;  // nothing moved within this cascade's map
    const double share = double(r.z - r.x) * double(r.w - r.y) / (double(size) * size);
    if (share > kMaxRepairShare) return false;
    any = true;
  }
  if (!any) {  // nothing moved within the maps
    sunScene_ = scene.generation;
    return true;
  }

  beginShadowRendering(cmd, p, scene, sun_, /*keep=*/true);
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    const glm::ivec4& r = rects[c];
    if (r.x >= r.z || r.y >= r.w) continue;
    redrawRect(cmd, p, scene, fit, c, r);
  }
  endShadowRendering(cmd, sun_);
  sunScene_ = scene.generation;
  return true;
}

bool ShadowMaps::scrollSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                           const SunShadowFit& fit) {
  if (!sunReadable_ || sunScene_ == 0 || sunScene_ != scene.generation) return false;
  if (fit.cascades < 2 || fit.cascades != sunFit_.cascades || fit.tileSize != sunFit_.tileSize) {
    return false;
  }
  const int size = int(fit.tileSize);
  std::array<glm::ivec2, kMaxSunCascades> shifts{};
  double uncovered = 0.0;
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    const std::optional<glm::ivec2> shift =
        texelShift(sunFit_.viewProjection[c], fit.viewProjection[c], fit.tileSize);
    if (!shift || std::abs(shift->x) >= size || std::abs(shift->y) >= size) return false;
    shifts[c] = *shift;
    uncovered += double(size) * size - double(size - std::abs(shift->x)) * (size - std::abs(shift->y));
  }
  if (uncovered > kMaxScrollShare * double(size) * size * fit.cascades) return false;

  if (scrollScratch_.image == VK_NULL_HANDLE || scrollScratch_.extent.width != fit.tileSize) {
    scrollArena_.release();
    scrollScratch_ = scrollArena_.createImage2D(
        {fit.tileSize, fit.tileSize}, kDepthFormat,
        // (The attachment usage only because every image here gets a view.)
        VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
            VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT);
  }
  // Both images stay in GENERAL while the copies run (the atlas is source, then destination).
  {
    const gpu::ImageTransition toCopy[] = {
        {&sun_, kShadowReaders, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
         VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
         VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL},
        {&scrollScratch_, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
         VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL}};
    gpu::barrier(cmd, toCopy);
  }
  // Copy and copy back, one cascade at a time through the scratch tile: a region may not be
  // copied onto an overlapping region of the same image. What a cascade keeps lies at
  // old texels [max(0, -s), size - max(0, s)), new ones [max(0, s), size - max(0, -s)).
  const glm::uvec2 grid = sunAtlasGrid(fit.cascades);
  const VkImageSubresourceLayers depthLayer{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
  const auto copyDependency = [&](VkAccessFlags2 scratchBefore, VkAccessFlags2 scratchAfter,
                                  VkAccessFlags2 atlasBefore, VkAccessFlags2 atlasAfter) {
    const gpu::ImageTransition between[] = {
        {&scrollScratch_, VK_PIPELINE_STAGE_2_COPY_BIT, scratchBefore, VK_PIPELINE_STAGE_2_COPY_BIT,
         scratchAfter, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL},
        {&sun_, VK_PIPELINE_STAGE_2_COPY_BIT, atlasBefore, VK_PIPELINE_STAGE_2_COPY_BIT, atlasAfter,
         VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL}};
    gpu::barrier(cmd, between);
  };
  bool first = true;
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    const glm::ivec2 s = shifts[c];
    if (s == glm::ivec2(0)) continue;
    const glm::ivec2 tile{int((c % grid.x) * fit.tileSize), int((c / grid.x) * fit.tileSize)};
    const glm::ivec2 from{std::max(0, -s.x), std::max(0, -s.y)};
    const glm::ivec2 to{std::max(0, s.x), std::max(0, s.y)};
    const VkExtent3D kept{uint32_t(size - std::abs(s.x)), uint32_t(size - std::abs(s.y)), 1};
    if (!first) {  // the last copy back read the scratch and wrote the atlas
      copyDependency(VK_ACCESS_2_TRANSFER_READ_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    }
    first = false;
    const VkImageCopy out{depthLayer, {tile.x + from.x, tile.y + from.y, 0}, depthLayer,
                          {to.x, to.y, 0}, kept};
    vkCmdCopyImage(cmd, sun_.image, VK_IMAGE_LAYOUT_GENERAL, scrollScratch_.image,
                   VK_IMAGE_LAYOUT_GENERAL, 1, &out);
    copyDependency(VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                   VK_ACCESS_2_TRANSFER_READ_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const VkImageCopy back{depthLayer, {to.x, to.y, 0}, depthLayer,
                           {tile.x + to.x, tile.y + to.y, 0}, kept};
    vkCmdCopyImage(cmd, scrollScratch_.image, VK_IMAGE_LAYOUT_GENERAL, sun_.image,
                   VK_IMAGE_LAYOUT_GENERAL, 1, &back);
  }

  // The uncovered strips: the columns the move opened on one side, the rows on the other
  // (their corner twice: cleared and drawn again the same), each cleared and drawn with only the
  // casters reaching into it.
  beginShadowRendering(cmd, p, scene, sun_, /*keep=*/true, /*scrolled=*/true);
  for (uint32_t c = 0; c < fit.cascades; ++c) {
    const glm::ivec2 s = shifts[c];
    std::array<glm::ivec4, 2> strips{};
    size_t count = 0;
    if (s.x > 0) strips[count++] = {0, 0, s.x, size};
    if (s.x < 0) strips[count++] = {size + s.x, 0, size, size};
    if (s.y > 0) strips[count++] = {0, 0, size, s.y};
    if (s.y < 0) strips[count++] = {0, size + s.y, size, size};
    for (size_t i = 0; i < count; ++i) redrawRect(cmd, p, scene, fit, c, strips[i]);
  }
  endShadowRendering(cmd, sun_);
  sunFit_ = fit;
  return true;
}

bool ShadowMaps::sunHolds(const SceneBuffers& scene, const SunShadowFit& fit) const {
  return sunReadable_ && sunScene_ != 0 && sunScene_ == scene.generation && sunFit_.sameMaps(fit);
}

}  // namespace myriad::render
