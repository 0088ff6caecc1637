// A rendered frame's targets as typed arrays (format=npy, npz, exr) and as 16-bit grey values
// (format=png16): what each target holds, in which dtype and shape (reference.md "Frame
// formats"). Pure CPU code over render::Frame; no HTTP, no Vulkan.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "encode/arrays.h"
#include "render/frame.h"
#include "scene/scene.h"
#include "service/frame_query.h"

namespace myriad::service {

// `target` of `frame` (rendered for `request`: one of request.targets) as an array named as the
// target: final '|u1' HxWx3 sRGB when read back as its 8-bit picture (npy, npz), else '<f4'
// HxWx3 linear HDR radiance (exr); the id targets '<u4' HxW; the other targets '<f4', HxW for one
// channel, HxWxC for more (C = render::rawChannels), with ?depth=distance and ?space=camera
// applied. Channel names for EXR: R,G,B / X,Y,Z / U,V / Z (depth) / Y (one value) / id.
encode::Array targetArray(const render::Frame& frame, const FrameRequest& request,
                          render::Target target);
// The same in two steps, for an archive written in place (encode::NpzWriter): the array's
// name, dtype and shape; then its bytes written into `out` (exactly that many).
encode::NpzWriter::Member targetLayout(const render::Frame& frame, const FrameRequest& request,
                                       render::Target target);
void writeTarget(const render::Frame& frame, const FrameRequest& request, render::Target target,
                 std::span<uint8_t> out);

// K (3x3 float64: fx 0 cx / 0 fy cy / 0 0 1) and world_from_camera (4x4 float64, OpenCV camera
// axes: X-Myriad-Pose's matrix), the npz members K.npy and world_from_camera.npy.
encode::Array intrinsicsArray(const scene::Camera& camera, uint32_t width, uint32_t height);
encode::Array poseArray(const scene::Camera& camera);
// The same as an EXR header's metadata, with the frame's time and the session version.
encode::ExrMetadata exrMetadata(const scene::Camera& camera, uint32_t width, uint32_t height,
                                double time, const std::string& version);

// format=png16 of depth: metres per unit of the 16-bit values: 0.001 (millimetres) when the far
// plane is at most 65.535 m, else far / 65535 so that the whole range fits. 0 means no surface.
double depthScale(const scene::Camera& camera);
std::vector<uint16_t> depthAsUint16(const render::Frame& frame, const FrameRequest& request,
                                    double scale);
// An id target's 16-bit values. An id above 65535 is never wrapped: ProblemError 422
// (invalid-parameter naming format) with the id and its pixel, pointing to npy, exr or raw.
std::vector<uint16_t> labelsAsUint16(const render::Frame& frame, const FrameRequest& request,
                                     render::Target target);

// The raw values `target` came back in: 4 floats a pixel (frame.data, an extra, or the labels).
std::span<const float> valuesOf(const render::Frame& frame, const FrameRequest& request,
                                render::Target target);

}  // namespace myriad::service
