// An HTTP/1.1 request head read with bounds (RFC 9112 sections 2-3, 6): the bytes up to the blank
// line, scanned as they arrive so a line or a head over its limit is refused as soon as it is
// over, never held whole. The connection layer (service/http_connections.h) reads every head
// with this before a worker runs the request; httplib then parses a head known to be bounded.
// Pure functions of bytes: unit-tested and fuzzed (tests/fuzz/http_request.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace myriad::service::http {

struct HeadLimits {
  size_t maxRequestLine = 8192;   // 414 beyond (nginx: large_client_header_buffers 8k)
  size_t maxHeaderLine = 8192;    // 431 beyond
  size_t maxHeaderCount = 100;    // 431 beyond
  size_t maxHeadBytes = 32768;    // 431 beyond (nginx: 4 x 8k)
};

// Why a head is refused: the status and one sentence for the problem's detail.
struct HeadRefusal {
  int status = 400;
  std::string detail;
};

// Feeds on a growing buffer; call scan() after each read with the whole buffer so far.
class HeadScanner {
 public:
  enum class State { NeedMore, Complete, Refused };

  explicit HeadScanner(const HeadLimits& limits) : limits_(limits) {}

  // Scans the bytes not yet seen. Complete: the head is buffer[headStart(), headEnd()); what
  // follows is the body or the next request. Refused: refusal() says why.
  State scan(std::string_view buffer);

  size_t headStart() const { return headStart_; }  // after any empty lines before the request
  size_t headEnd() const { return headEnd_; }
  const HeadRefusal& refusal() const { return refusal_; }

  // The most bytes worth reading before the head must be complete or refused.
  size_t maxBuffer() const { return limits_.maxHeadBytes + maxLeadingBytes; }

  // Empty lines before a request line are ignored (RFC 9112 section 2.2), a few of them.
  static constexpr size_t maxLeadingBytes = 64;

 private:
  State refuse(int status, std::string detail);

  HeadLimits limits_;
  State state_ = State::NeedMore;
  size_t scanned_ = 0;    // bytes of the buffer looked at
  size_t lineStart_ = 0;  // where the current line began
  size_t headStart_ = 0;
  size_t headEnd_ = 0;
  size_t headerLines_ = 0;
  bool seenRequestLine_ = false;
  HeadRefusal refusal_;
};

// What the connection layer needs to know of a complete head; httplib parses the rest.
struct RequestHead {
  std::string method;
  std::string target;  // as sent: path and query
  std::string path;    // target up to '?'
  bool http10 = false;
  std::optional<uint64_t> contentLength;
  bool chunked = false;
  bool connectionClose = false;  // "Connection: close", or HTTP/1.0 without keep-alive
  std::optional<std::string> authorization;

  // Whether a body follows the head (a length above 0 or chunked framing).
  bool hasBody() const { return chunked || contentLength.value_or(0) > 0; }
};

// Parses a head found by HeadScanner (the bytes from headStart() to headEnd()). Refuses what
// could make two parsers disagree about where the request ends (RFC 9112 section 6.3, 11.2):
// Content-Length with Transfer-Encoding, differing or malformed lengths, a coding other than
// chunked, obsolete line folding, control bytes.
struct ParsedHead {
  std::optional<RequestHead> head;
  HeadRefusal refusal;  // when head is empty
};
ParsedHead parseHead(std::string_view head);

// Follows a chunked body's framing (RFC 9112 section 7.1) as its bytes pass, without keeping them:
// bounds what a parser downstream would buffer (a chunk-size line, a trailer line) and says when
// the body has ended, so a connection can be kept for the next request only when it has.
class ChunkedFraming {
 public:
  static constexpr size_t kMaxSizeLine = 1024;  // hex digits and extensions

  // False (and failed() from then on) when the bytes break the framing or its bounds. Strict
  // where httplib 0.11, which reads the body, is lax or different: CR LF line ends, a size line
  // that starts with a hex digit, CR LF after each chunk's data, no trailer fields.
  bool feed(std::string_view bytes);
  bool done() const { return state_ == State::Done; }
  bool failed() const { return state_ == State::Failed; }
  // The bytes after the body's end in the last feed (the next request's), when done().
  size_t overrun() const { return overrun_; }

 private:
  enum class State { SizeLine, SizeLf, Data, DataCr, DataLf, LastCr, LastLf, Done, Failed };
  State state_ = State::SizeLine;
  uint64_t size_ = 0;       // of the chunk being read
  size_t digits_ = 0;       // hex digits of the size line so far
  bool sizeEnded_ = false;  // past the digits (an extension follows)
  size_t lineBytes_ = 0;
  size_t overrun_ = 0;
};

}  // namespace myriad::service::http
