// Frames as arrays for data users: NumPy's .npy and .npz, and OpenEXR. Plain CPU code, like the
// image encoders: it knows typed arrays and their names, not the renderer's targets (the service
// turns a frame's targets into Arrays: service/frame_arrays.h).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace myriad::encode {

// Element types, as NumPy names them: '<f4', '<u4', '|u1', '<f8' (little-endian).
enum class Dtype { F4, U4, U1, F8 };
size_t dtypeBytes(Dtype d);
const char* npyDescr(Dtype d);

// One named array: rows top first, channels last (HxW, HxWxC, or any shape for small ones such
// as 3x3), little-endian elements, C order.
struct Array {
  std::string name;                   // the npz member (name + ".npy") and the EXR layer
  Dtype dtype = Dtype::F4;
  std::vector<size_t> shape;
  std::vector<std::string> channels;  // EXR channel names of the last axis (one for HxW)
  std::vector<uint8_t> bytes;
  size_t elements() const;
};

// NumPy format version 1.0 (numpy.lib.format): magic, version, header length, the header dict
// padded with spaces to a multiple of 64 bytes with its newline, then the data. Throws
// std::invalid_argument when bytes.size() does not match the shape.
std::string writeNpy(const Array& array);
// The header alone (magic to newline; a multiple of 64 bytes) of an array of `dtype` and `shape`
// named `name` (named in a problem only).
std::string npyHeader(const std::string& name, Dtype dtype, const std::vector<size_t>& shape);

// An .npz: a zip archive (stored, no compression: the arrays are mostly noise to deflate, and
// numpy.load reads them in place) holding `<name>.npy` per array. Throws std::invalid_argument
// past the zip format's 4 GiB or 65,535 members (no Zip64).
std::string writeNpz(std::span<const Array> arrays);

// An .npz written in place, for frames of several large arrays: the members are laid out first
// (their headers written, the archive allocated once), then each member's data is written by the
// caller straight into the archive (`data(i)`), then finish() adds the CRC-32s (libdeflate's) and
// the central directory. No array is held or copied besides the archive itself.
class NpzWriter {
 public:
  struct Member {
    std::string name;  // without ".npy"
    Dtype dtype = Dtype::F4;
    std::vector<size_t> shape;
  };
  // Throws std::invalid_argument past the zip format's limits.
  explicit NpzWriter(std::span<const Member> members);
  // Where member i's data goes: exactly elements x dtype bytes, uninitialised (zeros) until
  // written.
  std::span<uint8_t> data(size_t i);
  // The archive; the writer is spent.
  std::string finish() &&;

 private:
  struct Placed {
    std::string file;   // "<name>.npy"
    size_t local = 0;   // offset of its local header
    size_t start = 0;   // offset of its .npy (header then data)
    size_t header = 0;  // bytes of the .npy header
    size_t size = 0;    // bytes of the whole .npy
  };
  std::vector<Placed> placed_;
  size_t directory_ = 0;
  std::string out_;
};

// A read back of writeNpz's archives (tests): each member's name and bytes. Checks the
// signatures, sizes and CRC-32s; throws std::invalid_argument otherwise.
std::vector<std::pair<std::string, std::string>> readZip(std::string_view zip);

// OpenEXR's sample precision for float channels (?precision=): 32-bit float (exact) or 16-bit
// half. Integer channels (ids) are always UINT.
enum class ExrPrecision { Float, Half };

// What an EXR's header says besides its channels: the camera and the frame.
struct ExrMetadata {
  std::array<double, 9> K{};                // 3x3 intrinsics, row-major
  std::array<double, 16> worldFromCamera{}; // 4x4, row-major (OpenCV camera axes)
  double nearPlane = 0.0, farPlane = 0.0;
  double time = 0.0;
  std::string version;                      // the session version the frame shows
  std::string software;                     // "myriad <server version>"
};

// A scanline OpenEXR file (ZIP-compressed, lossless) of `images` (each HxW or HxWxC of F4 or U4,
// all the same size): channel `<layer>.<channel>` per image and channel (F4 as `precision`, U4
// as UINT), plus the metadata as header attributes: K (m33d), worldFromCamera (m44d), near,
// far, time (double), myriadVersion, software (string). Throws std::invalid_argument for
// sizes that differ, other dtypes or a name OpenEXR cannot take.
std::string writeExr(std::span<const Array> images, ExrPrecision precision,
                     const ExrMetadata& metadata);

}  // namespace myriad::encode
