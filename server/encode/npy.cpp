#include "encode/arrays.h"

#include <libdeflate.h>
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

std::string npyHeader(const std::string& name, Dtype dtype, const std::vector<size_t>& shape) {
  std::string dims = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    dims += std::to_string(shape[i]);
    dims += shape.size() == 1 ? "," : i + 1 < shape.size() ? ", " : "";
  }
  dims += ")";
  std::string dict = std::string("{'descr': '") + npyDescr(dtype) +
                     "', 'fortran_order': False, 'shape': " + dims + ", }";
  // Magic (6) + version (2) + length (2) + dict + padding + newline: a multiple of 64, so the
  // data is aligned for any dtype.
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  if (dict.size() > std::numeric_limits<uint16_t>::max()) {
    throw std::invalid_argument("writeNpy: the header of " + name + " is too long");
  }
  std::string out;
  out.reserve(10 + dict.size());
  out.append("\x93NUMPY", 6);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(char(dict.size() & 0xff));
  out.push_back(char(dict.size() >> 8));
  out += dict;
  return out;
}

std::string writeNpy(const Array& array) {
  if (array.bytes.size() != array.elements() * dtypeBytes(array.dtype)) {
    throw std::invalid_argument("writeNpy: " + std::to_string(array.bytes.size()) +
                                " bytes do not fill the shape of " + array.name);
  }
  std::string out = npyHeader(array.name, array.dtype, array.shape);
  out.append(reinterpret_cast<const char*>(array.bytes.data()), array.bytes.size());
  return out;
}

namespace {

void put16(char* at, uint32_t v) {
  at[0] = char(v & 0xff);
  at[1] = char((v >> 8) & 0xff);
}
void put32(char* at, uint32_t v) {
  put16(at, v & 0xffff);
  put16(at + 2, v >> 16);
}

uint32_t get16(std::string_view s, size_t at) {
  if (at + 2 > s.size()) throw std::invalid_argument("zip: truncated");
  return uint32_t(uint8_t(s[at])) | uint32_t(uint8_t(s[at + 1])) << 8;
}
uint32_t get32(std::string_view s, size_t at) { return get16(s, at) | get16(s, at + 2) << 16; }

// MS-DOS time and date of 1980-01-01 00:00: archives of the same arrays are the same bytes.
constexpr uint32_t kDosTime = 0;
constexpr uint32_t kDosDate = (0 << 9) | (1 << 5) | 1;
// APPNOTE 4.3.7, 4.3.12, 4.3.16: the fixed parts of a local header, a directory entry and the
// end of the directory.
constexpr size_t kLocalHeader = 30, kDirectoryEntry = 46, kDirectoryEnd = 22;

}  // namespace

NpzWriter::NpzWriter(std::span<const Member> members) {
  if (members.size() > 0xffff) throw std::invalid_argument("writeNpz: more than 65,535 arrays");
  std::vector<std::string> headers;
  size_t at = 0;
  for (const Member& m : members) {
    size_t elements = 1;
    for (size_t d : m.shape) elements *= d;
    headers.push_back(npyHeader(m.name, m.dtype, m.shape));
    Placed p;
    p.file = m.name + ".npy";
    p.local = at;
    p.start = at + kLocalHeader + p.file.size();
    p.header = headers.back().size();
    p.size = p.header + elements * dtypeBytes(m.dtype);
    at = p.start + p.size;
    placed_.push_back(std::move(p));
  }
  directory_ = at;
  size_t total = at + kDirectoryEnd;
  for (const Placed& p : placed_) total += kDirectoryEntry + p.file.size();
  if (total > 0xffffffffull) {
    throw std::invalid_argument("writeNpz: the arrays are past the zip format's 4 GiB (no Zip64)");
  }
  out_.resize(total);
  for (size_t i = 0; i < placed_.size(); ++i) {
    const Placed& p = placed_[i];
    std::memcpy(out_.data() + p.start - p.file.size(), p.file.data(), p.file.size());
    std::memcpy(out_.data() + p.start, headers[i].data(), p.header);
  }
}

std::span<uint8_t> NpzWriter::data(size_t i) {
  const Placed& p = placed_.at(i);
  return {reinterpret_cast<uint8_t*>(out_.data() + p.start + p.header), p.size - p.header};
}

std::string NpzWriter::finish() && {
  char* zip = out_.data();
  char* entry = zip + directory_;
  for (const Placed& p : placed_) {
    const uint32_t crc = libdeflate_crc32(0, zip + p.start, p.size);
    const uint32_t size = uint32_t(p.size), name = uint32_t(p.file.size());
    // Local file header: stored, sizes known up front.
    char* local = zip + p.local;
    put32(local, 0x04034b50);
    put16(local + 4, 20);  // version needed: 2.0
    put16(local + 6, 0);   // flags
    put16(local + 8, 0);   // method: stored
    put16(local + 10, kDosTime);
    put16(local + 12, kDosDate);
    put32(local + 14, crc);
    put32(local + 18, size);
    put32(local + 22, size);
    put16(local + 26, name);
    put16(local + 28, 0);  // extra field length
    // Its central directory entry.
    put32(entry, 0x02014b50);
    put16(entry + 4, 20);  // version made by
    put16(entry + 6, 20);  // version needed
    put16(entry + 8, 0);
    put16(entry + 10, 0);
    put16(entry + 12, kDosTime);
    put16(entry + 14, kDosDate);
    put32(entry + 16, crc);
    put32(entry + 20, size);
    put32(entry + 24, size);
    put16(entry + 28, name);
    put16(entry + 30, 0);  // extra
    put16(entry + 32, 0);  // comment
    put16(entry + 34, 0);  // disk
    put16(entry + 36, 0);  // internal attributes
    put32(entry + 38, 0);  // external attributes
    put32(entry + 42, uint32_t(p.local));
    std::memcpy(entry + kDirectoryEntry, p.file.data(), name);
    entry += kDirectoryEntry + name;
  }
  const uint32_t count = uint32_t(placed_.size());
  put32(entry, 0x06054b50);
  put16(entry + 4, 0);
  put16(entry + 6, 0);
  put16(entry + 8, count);
  put16(entry + 10, count);
  put32(entry + 12, uint32_t(entry - zip - directory_));
  put32(entry + 16, uint32_t(directory_));
  put16(entry + 20, 0);  // comment length
  return std::move(out_);
}

std::string writeNpz(std::span<const Array> arrays) {
  std::vector<NpzWriter::Member> members;
  for (const Array& a : arrays) {
    if (a.bytes.size() != a.elements() * dtypeBytes(a.dtype)) {
      throw std::invalid_argument("writeNpy: " + std::to_string(a.bytes.size()) +
                                  " bytes do not fill the shape of " + a.name);
    }
    members.push_back({a.name, a.dtype, a.shape});
  }
  NpzWriter writer(members);
  for (size_t i = 0; i < arrays.size(); ++i) {
    if (!arrays[i].bytes.empty()) {
      std::memcpy(writer.data(i).data(), arrays[i].bytes.data(), arrays[i].bytes.size());
    }
  }
  return std::move(writer).finish();
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
