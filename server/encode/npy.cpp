#include "encode/arrays.h"

#include <zlib.h>

#include <cstring>
#include <limits>

namespace myriad::encode {

size_t dtypeBytes(Dtype d) {
  switch (d) {
    case Dtype::F4: return 4;
    case Dtype::U4: return 4;
    case Dtype::U1: return 1;
    case Dtype::F8: return 8;
  }
  return 1;
}

const char* npyDescr(Dtype d) {
  switch (d) {
    case Dtype::F4: return "<f4";
    case Dtype::U4: return "<u4";
    case Dtype::U1: return "|u1";
    case Dtype::F8: return "<f8";
  }
  return "|u1";
}

size_t Array::elements() const {
  size_t n = 1;
  for (size_t s : shape) n *= s;
  return n;
}

std::string writeNpy(const Array& array) {
  if (array.bytes.size() != array.elements() * dtypeBytes(array.dtype)) {
    throw std::invalid_argument("writeNpy: " + std::to_string(array.bytes.size()) +
                                " bytes do not fill the shape of " + array.name);
  }
  std::string shape = "(";
  for (size_t i = 0; i < array.shape.size(); ++i) {
    shape += std::to_string(array.shape[i]);
    shape += array.shape.size() == 1 ? "," : i + 1 < array.shape.size() ? ", " : "";
  }
  shape += ")";
  std::string dict = std::string("{'descr': '") + npyDescr(array.dtype) +
                     "', 'fortran_order': False, 'shape': " + shape + ", }";
  // Magic (6) + version (2) + length (2) + dict + padding + newline: a multiple of 64, so the
  // data is aligned for any dtype.
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  if (dict.size() > std::numeric_limits<uint16_t>::max()) {
    throw std::invalid_argument("writeNpy: the header of " + array.name + " is too long");
  }
  std::string out;
  out.reserve(10 + dict.size() + array.bytes.size());
  out.append("\x93NUMPY", 6);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(char(dict.size() & 0xff));
  out.push_back(char(dict.size() >> 8));
  out += dict;
  out.append(reinterpret_cast<const char*>(array.bytes.data()), array.bytes.size());
  return out;
}

namespace {

void put16(std::string& out, uint32_t v) {
  out.push_back(char(v & 0xff));
  out.push_back(char((v >> 8) & 0xff));
}
void put32(std::string& out, uint32_t v) {
  put16(out, v & 0xffff);
  put16(out, v >> 16);
}

uint32_t get16(std::string_view s, size_t at) {
  if (at + 2 > s.size()) throw std::invalid_argument("zip: truncated");
  return uint32_t(uint8_t(s[at])) | uint32_t(uint8_t(s[at + 1])) << 8;
}
uint32_t get32(std::string_view s, size_t at) { return get16(s, at) | get16(s, at + 2) << 16; }

// MS-DOS time and date of 1980-01-01 00:00: archives of the same arrays are the same bytes.
constexpr uint32_t kDosTime = 0;
constexpr uint32_t kDosDate = (0 << 9) | (1 << 5) | 1;

}  // namespace

std::string writeNpz(std::span<const Array> arrays) {
  struct Member {
    std::string name;
    uint32_t crc, size, offset;
  };
  std::vector<Member> members;
  std::string out;
  size_t total = 0;
  for (const Array& a : arrays) total += a.bytes.size() + 200 + 2 * a.name.size();
  if (arrays.size() > 0xffff || total > 0xffffffffull) {
    throw std::invalid_argument("writeNpz: the arrays are past the zip format's 4 GiB (no Zip64)");
  }
  out.reserve(total + 64);
  for (const Array& a : arrays) {
    const std::string npy = writeNpy(a);
    Member m{a.name + ".npy", 0, uint32_t(npy.size()), uint32_t(out.size())};
    m.crc = uint32_t(crc32(crc32(0, nullptr, 0), reinterpret_cast<const Bytef*>(npy.data()),
                           uInt(npy.size())));
    // Local file header (APPNOTE 4.3.7): stored, sizes known up front.
    put32(out, 0x04034b50);
    put16(out, 20);  // version needed: 2.0
    put16(out, 0);   // flags
    put16(out, 0);   // method: stored
    put16(out, kDosTime);
    put16(out, kDosDate);
    put32(out, m.crc);
    put32(out, m.size);
    put32(out, m.size);
    put16(out, uint32_t(m.name.size()));
    put16(out, 0);  // extra field length
    out += m.name;
    out += npy;
    members.push_back(std::move(m));
  }
  const uint32_t directory = uint32_t(out.size());
  for (const Member& m : members) {
    put32(out, 0x02014b50);
    put16(out, 20);  // version made by
    put16(out, 20);  // version needed
    put16(out, 0);
    put16(out, 0);
    put16(out, kDosTime);
    put16(out, kDosDate);
    put32(out, m.crc);
    put32(out, m.size);
    put32(out, m.size);
    put16(out, uint32_t(m.name.size()));
    put16(out, 0);  // extra
    put16(out, 0);  // comment
    put16(out, 0);  // disk
    put16(out, 0);  // internal attributes
    put32(out, 0);  // external attributes
    put32(out, m.offset);
    out += m.name;
  }
  const uint32_t directorySize = uint32_t(out.size()) - directory;
  put32(out, 0x06054b50);
  put16(out, 0);
  put16(out, 0);
  put16(out, uint32_t(members.size()));
  put16(out, uint32_t(members.size()));
  put32(out, directorySize);
  put32(out, directory);
  put16(out, 0);  // comment length
  return out;
}

std::vector<std::pair<std::string, std::string>> readZip(std::string_view zip) {
  if (zip.size() < 22) throw std::invalid_argument("zip: too short");
  const size_t end = zip.size() - 22;
  if (get32(zip, end) != 0x06054b50) throw std::invalid_argument("zip: no end of directory");
  const uint32_t count = get16(zip, end + 10);
  size_t at = get32(zip, end + 16);
  std::vector<std::pair<std::string, std::string>> members;
  for (uint32_t i = 0; i < count; ++i) {
    if (get32(zip, at) != 0x02014b50) throw std::invalid_argument("zip: bad directory entry");
    const uint32_t crc = get32(zip, at + 16), size = get32(zip, at + 20);
    const uint32_t nameLength = get16(zip, at + 28), extra = get16(zip, at + 30),
                   comment = get16(zip, at + 32);
    const uint32_t local = get32(zip, at + 42);
    if (get16(zip, at + 10) != 0) throw std::invalid_argument("zip: a member is compressed");
    const std::string name(zip.substr(at + 46, nameLength));
    at += 46 + nameLength + extra + comment;
    if (get32(zip, local) != 0x04034b50) throw std::invalid_argument("zip: bad local header");
    const size_t data = local + 30 + get16(zip, local + 26) + get16(zip, local + 28);
    if (data + size > zip.size()) throw std::invalid_argument("zip: truncated member");
    std::string bytes(zip.substr(data, size));
    if (uint32_t(crc32(crc32(0, nullptr, 0), reinterpret_cast<const Bytef*>(bytes.data()),
                       uInt(bytes.size()))) != crc) {
      throw std::invalid_argument("zip: CRC-32 of " + name + " does not match");
    }
    members.emplace_back(name, std::move(bytes));
  }
  return members;
}

}  // namespace myriad::encode
