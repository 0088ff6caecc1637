#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfMatrixAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImathBox.h>
#include <half.h>

#include <cstring>

#include "encode/arrays.h"

namespace myriad::encode {
namespace {

// OpenEXR writes through a stream it may seek back in (the line offset table): one in memory.
class MemoryStream : public Imf::OStream {
 public:
  MemoryStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (position_ + size_t(n) > bytes.size()) bytes.resize(position_ + size_t(n));
    std::memcpy(bytes.data() + position_, c, size_t(n));
    position_ += size_t(n);
  }
  uint64_t tellp() override { return position_; }
  void seekp(uint64_t pos) override { position_ = pos; }
  std::string bytes;

 private:
  size_t position_ = 0;
};

}  // namespace

std::string writeExr(std::span<const Array> images, ExrPrecision precision,
                     const ExrMetadata& metadata) {
  if (images.empty()) throw std::invalid_argument("writeExr: no images");
  const size_t height = images[0].shape.at(0), width = images[0].shape.at(1);
  if (width == 0 || height == 0 || width > 0x7fffffff || height > 0x7fffffff) {
    throw std::invalid_argument("writeExr: bad size");
  }
  Imf::Header header{static_cast<int>(width), static_cast<int>(height)};
  header.compression() = Imf::ZIP_COMPRESSION;
  Imath::M33d k;
  Imath::M44d pose;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) k[r][c] = metadata.K[size_t(r) * 3 + size_t(c)];
  }
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) pose[r][c] = metadata.worldFromCamera[size_t(r) * 4 + size_t(c)];
  }
  header.insert("K", Imf::M33dAttribute(k));
  header.insert("worldFromCamera", Imf::M44dAttribute(pose));
  header.insert("near", Imf::DoubleAttribute(metadata.nearPlane));
  header.insert("far", Imf::DoubleAttribute(metadata.farPlane));
  header.insert("time", Imf::DoubleAttribute(metadata.time));
  header.insert("myriadVersion", Imf::StringAttribute(metadata.version));
  header.insert("software", Imf::StringAttribute(metadata.software));

  // Half channels need their own copy; float and uint channels are read in place (a stride of
  // the array's channel count).
  std::vector<std::vector<half>> halves;
  Imf::FrameBuffer buffer;
  for (const Array& image : images) {
    const size_t channels = image.shape.size() == 3 ? image.shape[2] : 1;
    if (image.shape.size() < 2 || image.shape[0] != height || image.shape[1] != width ||
        (image.dtype != Dtype::F4 && image.dtype != Dtype::U4) ||
        image.channels.size() != channels ||
        image.bytes.size() != width * height * channels * 4) {
      throw std::invalid_argument("writeExr: " + image.name +
                                  " is not an HxW(xC) float32 or uint32 array of the frame's size");
    }
    for (size_t c = 0; c < channels; ++c) {
      const std::string name = image.name + "." + image.channels[c];
      const char* base = reinterpret_cast<const char*>(image.bytes.data()) + c * 4;
      const size_t xStride = channels * 4;
      if (image.dtype == Dtype::U4) {
        header.channels().insert(name, Imf::Channel(Imf::UINT));
        buffer.insert(name, Imf::Slice(Imf::UINT, const_cast<char*>(base), xStride, xStride * width));
      } else if (precision == ExrPrecision::Float) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        buffer.insert(name, Imf::Slice(Imf::FLOAT, const_cast<char*>(base), xStride, xStride * width));
      } else {
        header.channels().insert(name, Imf::Channel(Imf::HALF));
        std::vector<half>& h = halves.emplace_back(width * height);
        for (size_t i = 0; i < width * height; ++i) {
          float v;
          std::memcpy(&v, base + i * xStride, 4);
          h[i] = half(v);
        }
        buffer.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data()), sizeof(half),
                                       sizeof(half) * width));
      }
    }
  }
  MemoryStream stream;
  {
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(buffer);
    file.writePixels(int(height));
  }
  return std::move(stream.bytes);
}

}  // namespace myriad::encode
