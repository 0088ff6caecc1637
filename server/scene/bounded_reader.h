// Bytes in memory read through stb_image's callbacks (stbi_io_callbacks: read, skip, eof), so
// that a read past the end is seen: stb_image reads past the end of a truncated file as zeros
// without saying so, and a decoder asking for bytes after the last one means the file is short.
// Used by the texture readers (scene/image_decode_stb.cpp) and the .hdr reader
// (loader/hdr_decode.cpp); no stb_image of its own, so each keeps its own internal copy.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string_view>

namespace myriad::scene {

struct BoundedReader {
  std::string_view bytes;
  size_t at = 0;
  bool readPastEnd = false;
  // What a read past the end is given: nothing (stb_image then reads zeros itself), or a whole
  // read of this byte (a decoder that loops on zeros then ends; hdr_decode.cpp says why).
  std::optional<char> pastEndFill;

  // stb_image reads through a buffer of its own and asks for more than is left near the end (a
  // short read is normal); it asks again only once it needs a byte beyond the last one.
  static int read(void* user, char* out, int size) {
    auto* r = static_cast<BoundedReader*>(user);
    const size_t wanted = size_t(std::max(size, 0));
    const size_t left = r->bytes.size() - r->at;
    if (left == 0) {
      r->readPastEnd = true;
      if (!r->pastEndFill) return 0;
      std::memset(out, *r->pastEndFill, wanted);
      return int(wanted);
    }
    const size_t n = std::min(left, wanted);
    std::memcpy(out, r->bytes.data() + r->at, n);
    r->at += n;
    return int(n);
  }

  static void skip(void* user, int n) {
    auto* r = static_cast<BoundedReader*>(user);
    if (n < 0) {
      r->at -= std::min(r->at, size_t(-int64_t(n)));
    } else if (size_t(n) > r->bytes.size() - r->at) {
      r->at = r->bytes.size();
      r->readPastEnd = true;
    } else {
      r->at += size_t(n);
    }
  }

  // Asked before a read, to know whether one could give more: not itself a read past the end.
  static int eof(void* user) {
    const auto* r = static_cast<const BoundedReader*>(user);
    return r->at >= r->bytes.size() ? 1 : 0;
  }
};

}  // namespace myriad::scene
