#include "multipart.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace myriad::cli {
namespace {

// A header block this long without a line end is not a frame stream.
constexpr size_t kMaxHeaderLine = 64 * 1024;

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return text;
}

std::string trim(const std::string& text) {
  size_t begin = text.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  size_t end = text.find_last_not_of(" \t");
  return text.substr(begin, end - begin + 1);
}

}  // namespace

std::optional<std::string> multipartBoundary(const std::string& contentType) {
  std::string lower = lowercase(contentType);
  if (!lower.starts_with("multipart/")) return std::nullopt;
  size_t at = lower.find("boundary=");
  if (at == std::string::npos) return std::nullopt;
  std::string value = contentType.substr(at + 9);
  if (!value.empty() && value.front() == '"') {
    size_t close = value.find('"', 1);
    if (close == std::string::npos) return std::nullopt;
    value = value.substr(1, close - 1);
  } else {
    value = trim(value.substr(0, value.find(';')));
  }
  if (value.empty()) return std::nullopt;
  return value;
}

MultipartReader::MultipartReader(std::string boundary) : delimiter_("--" + std::move(boundary)) {}

std::vector<MultipartPart> MultipartReader::feed(std::string_view bytes) {
  std::vector<MultipartPart> parts;
  buffer_.append(bytes);
  for (;;) {
    switch (state_) {
      case State::SeekBoundary: {
        size_t at = buffer_.find(delimiter_);
        if (at == std::string::npos) {
          // Keep a tail that may be the start of a delimiter split across reads.
          if (buffer_.size() >= delimiter_.size()) {
            buffer_.erase(0, buffer_.size() - (delimiter_.size() - 1));
          }
          return parts;
        }
        buffer_.erase(0, at + delimiter_.size());
        state_ = State::AfterBoundary;
        break;
      }
      case State::AfterBoundary: {
        if (buffer_.size() < 2) return parts;
        if (buffer_.starts_with("--")) {
          state_ = State::Done;
          buffer_.clear();
          return parts;
        }
        size_t end = buffer_.find('\n');
        if (end == std::string::npos) {
          if (buffer_.size() > kMaxHeaderLine) throw std::runtime_error("boundary line too long");
          return parts;
        }
        buffer_.erase(0, end + 1);  // the rest of the boundary line (transport padding, CR)
        part_ = MultipartPart{};
        contentLength_.reset();
        state_ = State::Headers;
        break;
      }
      case State::Headers: {
        size_t end = buffer_.find('\n');
        if (end == std::string::npos) {
          if (buffer_.size() > kMaxHeaderLine) throw std::runtime_error("part header too long");
          return parts;
        }
        std::string line = buffer_.substr(0, end);
        buffer_.erase(0, end + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) {
          state_ = State::Body;
          break;
        }
        size_t colon = line.find(':');
        if (colon == std::string::npos || colon == 0) {
          throw std::runtime_error("malformed part header \"" + line.substr(0, 80) + "\"");
        }
        std::string name = lowercase(trim(line.substr(0, colon)));
        std::string value = trim(line.substr(colon + 1));
        if (name == "content-length") {
          if (value.empty() || value.size() > 15 ||
              value.find_first_not_of("0123456789") != std::string::npos) {
            throw std::runtime_error("malformed Content-Length \"" + value.substr(0, 40) + "\"");
          }
          contentLength_ = std::stoull(value);
        }
        part_.headers[name] = value;
        break;
      }
      case State::Body: {
        if (contentLength_) {
          if (buffer_.size() < *contentLength_) return parts;
          part_.body = buffer_.substr(0, *contentLength_);
          buffer_.erase(0, *contentLength_);
        } else {
          size_t at = buffer_.find("\r\n" + delimiter_);
          if (at == std::string::npos) return parts;
          part_.body = buffer_.substr(0, at);
          buffer_.erase(0, at + 2);
        }
        parts.push_back(std::move(part_));
        part_ = MultipartPart{};
        state_ = State::SeekBoundary;
        break;
      }
      case State::Done:
        buffer_.clear();
        return parts;
    }
  }
}

}  // namespace myriad::cli
