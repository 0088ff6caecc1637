// Incremental reader of a multipart/x-mixed-replace body (GET .../stream): bytes go in as they
// arrive, whole parts come out. Pure, no I/O, so it is tested on hand-made and split input.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace myriad::cli {

struct MultipartPart {
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
};

// The boundary parameter of a multipart Content-Type ("multipart/x-mixed-replace;
// boundary=myriad-frame" -> "myriad-frame"), quotes removed; nullopt when there is none.
std::optional<std::string> multipartBoundary(const std::string& contentType);

class MultipartReader {
 public:
  explicit MultipartReader(std::string boundary);

  // Adds `bytes`; returns the parts completed by them, in order. A part ends after its
  // Content-Length bytes when it has that header, else at the next boundary line.
  // Throws std::runtime_error on a malformed part (bad header line, bad Content-Length).
  std::vector<MultipartPart> feed(std::string_view bytes);

  bool finished() const { return state_ == State::Done; }  // the closing --boundary-- was read

 private:
  enum class State { SeekBoundary, AfterBoundary, Headers, Body, Done };

  std::string delimiter_;  // "--" + boundary
  std::string buffer_;
  State state_ = State::SeekBoundary;
  MultipartPart part_;
  std::optional<size_t> contentLength_;
};

}  // namespace myriad::cli
