// A small glTF 2.0 writer for tests: accessors over one embedded buffer (a base64 data URI),
// nodes, meshes, skins and animations given as JSON text. Only what the animation tests need.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace myriad::test {

class GltfBuilder {
 public:
  // Appends `count` elements of `type` ("SCALAR", "VEC3", ...) of `componentType` (5126 float,
  // 5123 unsigned short) and returns the accessor index. Min/max are written for positions.
  template <typename T>
  int accessor(const std::vector<T>& values, const char* type, int componentType, size_t count,
               const std::string& extra = "") {
    while (buffer_.size() % 4 != 0) buffer_.push_back('\0');
    const size_t offset = buffer_.size();
    buffer_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
    const int view = int(views_.size());
    views_.push_back("{\"buffer\":0,\"byteOffset\":" + std::to_string(offset) +
                     ",\"byteLength\":" + std::to_string(values.size() * sizeof(T)) + "}");
    accessors_.push_back("{\"bufferView\":" + std::to_string(view) + ",\"componentType\":" +
                         std::to_string(componentType) + ",\"count\":" + std::to_string(count) +
                         ",\"type\":\"" + type + "\"" + extra + "}");
    return int(accessors_.size()) - 1;
  }
  int floats(const std::vector<float>& values, const char* type, size_t width,
             const std::string& extra = "") {
    return accessor(values, type, 5126, values.size() / width, extra);
  }
  // Positions with the min and max glTF requires.
  int positions(const std::vector<float>& xyz) {
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t i = 0; i < xyz.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], xyz[i]);
      hi[i % 3] = std::max(hi[i % 3], xyz[i]);
    }
    auto list = [](const float* v) {
      std::ostringstream out;
      out << '[' << v[0] << ',' << v[1] << ',' << v[2] << ']';
      return out.str();
    };
    return floats(xyz, "VEC3", 3, ",\"min\":" + list(lo) + ",\"max\":" + list(hi));
  }

  std::vector<std::string> nodes, meshes, skins, animations;
  std::string sceneNodes = "[0]";

  std::string json() const {
    std::string out =
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":" + sceneNodes + "}],";
    out += "\"nodes\":" + list(nodes) + ",\"meshes\":" + list(meshes);
    if (!skins.empty()) out += ",\"skins\":" + list(skins);
    if (!animations.empty()) out += ",\"animations\":" + list(animations);
    out += ",\"accessors\":" + list(accessors_) + ",\"bufferViews\":" + list(views_);
    out += ",\"buffers\":[{\"byteLength\":" + std::to_string(buffer_.size()) +
           ",\"uri\":\"data:application/octet-stream;base64," + base64(buffer_) + "\"}]}";
    return out;
  }

 private:
  static std::string list(const std::vector<std::string>& items) {
    std::string out = "[";
    for (size_t i = 0; i < items.size(); ++i) out += (i ? "," : "") + items[i];
    return out + "]";
  }
  static std::string base64(const std::string& bytes) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
      const uint32_t v =
          (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
      out += digits[v >> 18], out += digits[(v >> 12) & 63], out += digits[(v >> 6) & 63],
          out += digits[v & 63];
    }
    if (i + 1 == bytes.size()) {
      const uint32_t v = uint8_t(bytes[i]) << 16;
      out += digits[v >> 18], out += digits[(v >> 12) & 63], out += "==";
    } else if (i + 2 == bytes.size()) {
      const uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8);
      out += digits[v >> 18], out += digits[(v >> 12) & 63], out += digits[(v >> 6) & 63],
          out += '=';
    }
    return out;
  }

  std::string buffer_;
  std::vector<std::string> views_, accessors_;
};

}  // namespace myriad::test
