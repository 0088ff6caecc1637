// Raw request bytes as a client sends them, through what the server does with them: the bounded
// head scanner and parser (server/service/http_head.h), fed in the pieces the input chooses, then,
// for a head they accept, httplib's request processing over an in-memory stream with a body route
// that reads multipart or plain bodies as the server's route table does, and the chunked framing
// follower over what httplib read of the body.
//
// Input: the first byte sets the size of the pieces the scanner is fed (1-32 bytes, or all at
// once); the rest is the connection's bytes (a head, a body, maybe more requests).
// Promises checked: scanning in pieces and at once agree; a complete head lies within the bounds
// (request line, header lines, count, total); a parsed head never has both a length and chunked
// framing, and its path is its target's prefix; httplib reads no more of the stream than the
// framing it was given allows; nothing throws out of the server's processing.
//
// httplib itself is Debian's shared library, not instrumented for coverage: the harness steers by
// our scanner's and parser's branches, while ASan still checks every allocation it makes.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include <httplib.h>

#include "fuzz_support.h"
#include "service/http_head.h"

namespace http = myriad::service::http;
using myriad::fuzz::require;

namespace {

// Small limits so the fuzzer reaches every bound with short inputs.
http::HeadLimits fuzzLimits() {
  http::HeadLimits limits;
  limits.maxRequestLine = 256;
  limits.maxHeaderLine = 128;
  limits.maxHeaderCount = 8;
  limits.maxHeadBytes = 1024;
  return limits;
}

// The bytes after the head, served to httplib; writes are dropped.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(std::string_view bytes) : bytes_(bytes) {}
  bool is_readable() const override { return position_ < bytes_.size(); }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    const size_t n = std::min(size, bytes_.size() - position_);
    std::memcpy(ptr, bytes_.data() + position_, n);
    position_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char*, size_t size) override { return static_cast<ssize_t>(size); }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 1;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 2;
  }
  socket_t socket() const override { return INVALID_SOCKET; }
  size_t position() const { return position_; }

 private:
  std::string_view bytes_;
  size_t position_ = 0;
};

// httplib's server with process_request reachable and the kinds of route Myriad has: a body read
// through a content reader (multipart or plain, bounded as the route table bounds it), a GET.
class Server : public httplib::Server {
 public:
  Server() {
    Post("/u", [](const httplib::Request& req, httplib::Response& res,
                  const httplib::ContentReader& reader) {
      size_t bytes = 0;
      size_t parts = 0;
      auto count = [&](size_t n) { return (bytes += n) <= 65536; };
      if (req.is_multipart_form_data()) {
        reader([&](const httplib::MultipartFormData& part) {
                 return ++parts <= 64 && count(64 + part.name.size() + part.filename.size());
               },
               [&](const char*, size_t n) { return count(n); });
      } else {
        reader([&](const char*, size_t n) { return count(n); });
      }
      res.set_content(std::to_string(bytes), "text/plain");
    });
    Get("/g", [](const httplib::Request& req, httplib::Response& res) {
      res.set_content(req.path, "text/plain");
    });
  }
  bool run(httplib::Stream& stream, bool& closed) {
    return process_request(stream, false, closed, nullptr);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t piece = data[0] % 33;  // 0: all at once
  const std::string_view input(reinterpret_cast<const char*>(data + 1), size - 1);
  const http::HeadLimits limits = fuzzLimits();

  http::HeadScanner whole(limits);
  const http::HeadScanner::State once = whole.scan(input);
  http::HeadScanner pieces(limits);
  http::HeadScanner::State state = http::HeadScanner::State::NeedMore;
  for (size_t end = piece == 0 ? input.size() : std::min(piece, input.size());;
       end = std::min(end + (piece == 0 ? input.size() : piece), input.size())) {
    state = pieces.scan(input.substr(0, end));
    if (state != http::HeadScanner::State::NeedMore || end == input.size()) break;
  }
  require(state == once, "scanning in pieces and at once disagree");
  if (state == http::HeadScanner::State::Refused) {
    const int status = pieces.refusal().status;
    require(status == 400 || status == 414 || status == 431, "refused with an unexpected status");
    require(!pieces.refusal().detail.empty(), "refused without a reason");
    return 0;
  }
  if (state != http::HeadScanner::State::Complete) return 0;
  require(pieces.headStart() == whole.headStart() && pieces.headEnd() == whole.headEnd(),
          "pieces and whole found different heads");
  const size_t start = pieces.headStart();
  const size_t end = pieces.headEnd();
  require(start <= http::HeadScanner::maxLeadingBytes, "too many leading bytes");
  require(end > start && end - start <= limits.maxHeadBytes + 2, "head over its bound");

  const http::ParsedHead parsed = http::parseHead(input.substr(start, end - start));
  if (!parsed.head) {
    require(parsed.refusal.status >= 400 && parsed.refusal.status < 600, "refusal not an error");
    return 0;
  }
  const http::RequestHead& head = *parsed.head;
  require(!(head.chunked && head.contentLength), "both a length and chunked framing");
  require(head.target.starts_with(head.path), "path not the target's prefix");

  // httplib on the same bytes (from the head on), as a worker runs it.
  const std::string_view connection = input.substr(start);
  MemoryStream stream(connection);
  Server server;
  bool closed = false;
  try {
    server.run(stream, closed);
  } catch (...) {
    myriad::fuzz::broken("httplib's request processing threw");
  }
  const size_t bodyRead = stream.position() > end - start ? stream.position() - (end - start) : 0;
  if (head.contentLength) {
    require(bodyRead <= *head.contentLength, "read past Content-Length");
  }
  if (head.chunked) {
    // What httplib took of a chunked body must be framing it could follow; it stops at the end.
    http::ChunkedFraming framing;
    const bool followed = framing.feed(connection.substr(end - start, bodyRead));
    require(!framing.done() || framing.overrun() == 0 || !followed,
            "httplib read past the end of a chunked body");
  }
  return 0;
}
