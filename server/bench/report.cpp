#include "bench/report.h"

#include <string>

namespace myriad::bench {

namespace {

double mebibytes(uint64_t bytes) { return double(bytes) / double(1 << 20); }

nlohmann::json summaryJson(const Summary& s) { return {{"median", s.median}, {"p90", s.p90}}; }

}  // namespace

void printHeader(std::FILE* out, const RunInfo& run) {
  const gpu::DeviceInfo& d = run.device;
  const std::string units =
      d.multiprocessors > 0 ? ", " + std::to_string(d.multiprocessors) + " multiprocessors" : "";
  std::fprintf(out, "device: %s (%s), driver %s %s, Vulkan %s, timestamp period %.3g ns%s\n",
               d.name.c_str(), d.type.c_str(), d.driverName.c_str(), d.driverInfo.c_str(),
               d.apiVersion.c_str(), d.timestampPeriodNs, units.c_str());
  std::fprintf(out, "started %s; scene %s; %u warm-up + %u timed frames (cap %.0f s); validation %s; "
                    "gbuffer %s\n",
               run.startedUtc.c_str(), run.scene.c_str(), run.plan.warmupFrames,
               run.plan.timedFrames, run.plan.maxSecondsPerConfig, run.validation ? "on" : "off",
               run.gbuffer.c_str());
  std::fprintf(out, "GPU times in ms from timestamp queries: median / p90. pairs: pixel-light pairs "
                    "shaded per frame; ceiling: %.2g pairs/s (H200 microkernel)\n",
               kH200PairsPerSecondCeiling);
  std::fprintf(out, "%-9s %-10s %8s %-9s %6s %17s %17s %9s %7s %8s %8s %9s %7s %8s %8s %5s\n",
               "scene", "size", "lights", "technique", "frames", "frame ms", "lighting ms",
               "pairs/px", "max/px", "Gpair/s", "ceiling", "entries", "active", "longest",
               "MiB", "valid");
}

void printResult(std::FILE* out, const ConfigResult& r) {
  char size[32];
  std::snprintf(size, sizeof size, "%ux%u", r.width, r.height);
  const std::string technique(render::techniqueName(r.technique));
  if (!r.skipped.empty()) {
    std::fprintf(out, "%-9s %-10s %8u %-9s skipped: %s\n", r.scene.c_str(), size, r.lights,
                 technique.c_str(), r.skipped.c_str());
    return;
  }
  const double pixels = double(r.width) * r.height;
  std::fprintf(out,
               "%-9s %-10s %8u %-9s %6u %8.3f/%8.3f %8.3f/%8.3f %9.2f %7u %8.3g %7.3g%% %9u %7u %8u "
               "%8.1f %5u\n",
               r.scene.c_str(), size, r.lights, technique.c_str(), r.timedFrames, r.totalMs.median,
               r.totalMs.p90, r.lightingMs.median, r.lightingMs.p90, double(r.pairs) / pixels,
               r.mostLightsAtPixel, r.pairsPerSecond * 1e-9, 100.0 * r.ceilingFraction,
               r.listEntries, r.activeClusters, r.mostLightsInList,
               mebibytes(r.lightBytes + r.listBytes), r.validationMessages);
  std::fprintf(out, "    passes:");
  for (const PassSummary& p : r.passes) {
    std::fprintf(out, " %s %.3f/%.3f", p.name.c_str(), p.ms.median, p.ms.p90);
  }
  std::fprintf(out, "; wall %.2f ms\n", r.wallMs.median);
  if (r.sunMapsDrawn + r.sunMapsScrolled + r.sunMapsKept > 0) {
    std::fprintf(out, "    sun maps: drawn %u, scrolled %u, kept %u of the timed frames\n",
                 r.sunMapsDrawn, r.sunMapsScrolled, r.sunMapsKept);
  }
  if (r.shadowRays > 0) {
    std::fprintf(out, "    shadow rays: %llu a frame, %.3g rays/s over the shadow-rays pass\n",
                 static_cast<unsigned long long>(r.shadowRays), r.raysPerSecond);
  }
  if (r.framesOverflowed > 0) {
    std::fprintf(out,
                 "    OVERFLOW in %u of %u frames: up to %u tiles over capacity, %u tile and %u "
                 "cluster light references dropped\n",
                 r.framesOverflowed, r.timedFrames, r.mostTilesOverflowed, r.mostTileLightsDropped,
                 r.mostClusterLightsDropped);
  }
  std::fflush(out);
}

nlohmann::json toJson(const RunInfo& run, const std::vector<ConfigResult>& results) {
  const gpu::DeviceInfo& d = run.device;
  nlohmann::json configs = nlohmann::json::array();
  for (const ConfigResult& r : results) {
    nlohmann::json c = {{"scene", r.scene},
                        {"width", r.width},
                        {"height", r.height},
                        {"lights", r.lights},
                        {"technique", render::techniqueName(r.technique)}};
    if (!r.skipped.empty()) {
      c["skipped"] = r.skipped;
      configs.push_back(std::move(c));
      continue;
    }
    nlohmann::json passes = nlohmann::json::array();
    for (const PassSummary& p : r.passes) passes.push_back({{"name", p.name}, {"ms", summaryJson(p.ms)}});
    c["warmup_frames"] = r.warmupFrames;
    c["timed_frames"] = r.timedFrames;
    c["passes"] = std::move(passes);
    c["frame_ms"] = summaryJson(r.totalMs);
    c["lighting_ms"] = summaryJson(r.lightingMs);
    c["wall_ms"] = summaryJson(r.wallMs);
    c["sun_maps"] = {{"drawn", r.sunMapsDrawn}, {"scrolled", r.sunMapsScrolled}, {"kept", r.sunMapsKept}};
    c["culling"] = {{"frames_overflowed", r.framesOverflowed},
                    {"most_tiles_overflowed", r.mostTilesOverflowed},
                    {"most_tile_lights_dropped", r.mostTileLightsDropped},
                    {"most_cluster_lights_dropped", r.mostClusterLightsDropped},
                    {"most_lights_in_list", r.mostLightsInList},
                    {"list_entries", r.listEntries},
                    {"active_clusters", r.activeClusters}};
    c["gpu_memory_bytes"] = {{"lights", r.lightBytes}, {"lists", r.listBytes}};
    c["pairs"] = r.pairs;
    c["pairs_per_pixel"] = double(r.pairs) / (double(r.width) * r.height);
    c["most_lights_at_pixel"] = r.mostLightsAtPixel;
    c["pairs_per_second"] = r.pairsPerSecond;
    c["fraction_of_h200_ceiling"] = r.ceilingFraction;
    c["validation_messages"] = r.validationMessages;
    if (r.shadowRays > 0) {
      c["shadow_rays"] = r.shadowRays;
      c["shadow_rays_per_second"] = r.raysPerSecond;
    }
    configs.push_back(std::move(c));
  }
  return {
      {"device",
       {{"name", d.name},
        {"type", d.type},
        {"driver_name", d.driverName},
        {"driver_info", d.driverInfo},
        {"vulkan", d.apiVersion},
        {"vendor_id", d.vendorId},
        {"device_id", d.deviceId},
        {"subgroup_size", d.subgroupSize},
        {"timestamp_period_ns", d.timestampPeriodNs}}},
      {"command", run.command},
      {"started_utc", run.startedUtc},
      {"scene", run.scene},
      {"lights_per_point", run.lightsPerPoint},
      {"seed", run.seed},
      {"gbuffer", run.gbuffer},
      {"warmup_frames", run.plan.warmupFrames},
      {"timed_frames", run.plan.timedFrames},
      {"max_seconds_per_config", run.plan.maxSecondsPerConfig},
      {"markers", run.plan.markers},
      {"antialias", run.plan.streamHistory ? "taa-stream" : render::antialiasName(run.plan.antialias)},
      {"sun_shadow_map", run.plan.sunShadowMap},
      {"sun_cascades", run.plan.sunShadowMap > 0 ? run.plan.sunCascades : 0},
      {"camera", run.plan.orbitCamera ? "orbit" : "still"},
      {"shadowed_lights", run.plan.shadowedLights},
      {"shadowed_kind", run.plan.shadowedSpots ? "spot" : "point"},
      {"ceiling_pairs_per_second", kH200PairsPerSecondCeiling},
      {"validation", {{"enabled", run.validation}, {"messages", run.validationMessages}}},
      {"configs", std::move(configs)},
  };
}

}  // namespace myriad::bench
