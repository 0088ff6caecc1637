#include "service/http_head.h"

#include <algorithm>
#include <cctype>
#include <vector>

namespace myriad::service::http {
namespace {

// RFC 9110 section 5.6.2: the characters of a method or a field name.
bool isTokenChar(unsigned char c) {
  if (std::isalnum(c) != 0) return true;
  constexpr std::string_view kExtra = "!#$%&'*+-.^_`|~";
  return kExtra.find(static_cast<char>(c)) != std::string_view::npos;
}

bool isToken(std::string_view text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
    return isTokenChar(static_cast<unsigned char>(c));
  });
}

std::string_view trimSpace(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

std::string lowered(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

bool equalsNoCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && lowered(a) == lowered(b);
}

// The comma-separated elements of a field value, trimmed, empty ones dropped (RFC 9110 5.6.1).
std::vector<std::string_view> listElements(std::string_view value) {
  std::vector<std::string_view> elements;
  size_t start = 0;
  while (start <= value.size()) {
    size_t comma = value.find(',', start);
    if (comma == std::string_view::npos) comma = value.size();
    std::string_view element = trimSpace(value.substr(start, comma - start));
    if (!element.empty()) elements.push_back(element);
    start = comma + 1;
  }
  return elements;
}

// Decimal digits only, at most 18 of them (so the value fits with room to add to it).
std::optional<uint64_t> parseLength(std::string_view text) {
  if (text.empty() || text.size() > 18) return std::nullopt;
  uint64_t value = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + static_cast<uint64_t>(c - '0');
  }
  return value;
}

ParsedHead refused(int status, std::string detail) {
  ParsedHead parsed;
  parsed.refusal = {status, std::move(detail)};
  return parsed;
}

}  // namespace

HeadScanner::State HeadScanner::refuse(int status, std::string detail) {
  refusal_ = {status, std::move(detail)};
  return state_ = State::Refused;
}

HeadScanner::State HeadScanner::scan(std::string_view buffer) {
  if (state_ != State::NeedMore) return state_;
  for (; scanned_ < buffer.size(); ++scanned_) {
    if (buffer[scanned_] == '\n') {
      // CR LF only: httplib skips a line ending in a bare LF, so a head read otherwise here
      // would be a different request there (a Transfer-Encoding one side sees and not the other).
      if (scanned_ == lineStart_ || buffer[scanned_ - 1] != '\r') {
        return refuse(400, "A line of the request head ends without CR LF.");
      }
      const size_t length = scanned_ - lineStart_ - 1;
      const size_t next = scanned_ + 1;
      if (!seenRequestLine_) {
        if (length == 0) {
          headStart_ = next;
          lineStart_ = next;
          if (headStart_ > maxLeadingBytes) {
            return refuse(400, "The request begins with empty lines instead of a request line.");
          }
          continue;
        }
        seenRequestLine_ = true;
      } else if (length == 0) {
        headEnd_ = next;
        ++scanned_;
        return state_ = State::Complete;
      } else if (++headerLines_ > limits_.maxHeaderCount) {
        return refuse(431, "The request has more than " + std::to_string(limits_.maxHeaderCount) +
                               " header fields.");
      }
      lineStart_ = next;
      continue;
    }
    // The current line so far, counting a CR that may end it.
    const size_t line = scanned_ + 1 - lineStart_;
    if (!seenRequestLine_ && line > limits_.maxRequestLine + 1) {
      return refuse(414, "The request line is longer than " +
                             std::to_string(limits_.maxRequestLine) + " bytes.");
    }
    if (seenRequestLine_ && line > limits_.maxHeaderLine + 1) {
      return refuse(431, "A header line is longer than " + std::to_string(limits_.maxHeaderLine) +
                             " bytes.");
    }
    if (scanned_ + 1 - headStart_ > limits_.maxHeadBytes) {
      return refuse(431, "The request head is larger than " +
                             std::to_string(limits_.maxHeadBytes) + " bytes.");
    }
  }
  return State::NeedMore;
}

ParsedHead parseHead(std::string_view text) {
  // The lines, without their CR LF; the last (empty) line ends the head.
  std::vector<std::string_view> lines;
  while (!text.empty()) {
    size_t end = text.find('\n');
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(0, end);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    text.remove_prefix(std::min(end + 1, text.size()));
  }
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  if (lines.empty()) return refused(400, "The request has no request line.");

  RequestHead head;
  const std::string_view requestLine = lines.front();
  const size_t firstSpace = requestLine.find(' ');
  const size_t lastSpace = requestLine.rfind(' ');
  if (firstSpace == std::string_view::npos || firstSpace == lastSpace) {
    return refused(400, "The request line is not 'METHOD target HTTP/1.1'.");
  }
  head.method = std::string(requestLine.substr(0, firstSpace));
  head.target = std::string(requestLine.substr(firstSpace + 1, lastSpace - firstSpace - 1));
  const std::string_view version = requestLine.substr(lastSpace + 1);
  if (!isToken(head.method)) return refused(400, "The request method is not a token.");
  if (head.target.empty() || std::any_of(head.target.begin(), head.target.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u <= 0x20 || u == 0x7f;
      })) {
    return refused(400, "The request target is empty or holds spaces or control bytes.");
  }
  if (version == "HTTP/1.0") {
    head.http10 = true;
  } else if (version != "HTTP/1.1") {
    return refused(505, "Only HTTP/1.1 and HTTP/1.0 are served.");
  }
  head.path = head.target.substr(0, head.target.find('?'));

  bool keepAlive = false;
  bool sawTransferEncoding = false;
  std::vector<std::string_view> codings;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    if (line.empty()) return refused(400, "The request head holds an empty line before its end.");
    if (line.front() == ' ' || line.front() == '\t') {
      return refused(400, "A header line is folded onto the next (obsolete line folding).");
    }
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos || !isToken(line.substr(0, colon))) {
      return refused(400, "A header line is not 'Name: value'.");
    }
    const std::string_view name = line.substr(0, colon);
    const std::string_view value = trimSpace(line.substr(colon + 1));
    if (std::any_of(value.begin(), value.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return (u < 0x20 && u != '\t') || u == 0x7f;
        })) {
      return refused(400, "The header " + std::string(name) + " holds control bytes.");
    }
    if (equalsNoCase(name, "Content-Length")) {
      for (std::string_view element : listElements(value)) {
        const std::optional<uint64_t> length = parseLength(element);
        if (!length) return refused(400, "Content-Length is not a decimal byte count.");
        if (head.contentLength && *head.contentLength != *length) {
          return refused(400, "The request gives two different Content-Lengths.");
        }
        head.contentLength = length;
      }
      if (!head.contentLength) return refused(400, "Content-Length is empty.");
    } else if (equalsNoCase(name, "Transfer-Encoding")) {
      sawTransferEncoding = true;
      for (std::string_view coding : listElements(value)) codings.push_back(coding);
    } else if (equalsNoCase(name, "Connection")) {
      for (std::string_view option : listElements(value)) {
        if (equalsNoCase(option, "close")) head.connectionClose = true;
        if (equalsNoCase(option, "keep-alive")) keepAlive = true;
      }
    } else if (equalsNoCase(name, "Authorization")) {
      head.authorization = std::string(value);
    }
  }
  if (sawTransferEncoding) {
    if (head.http10) return refused(400, "HTTP/1.0 has no Transfer-Encoding.");
    if (codings.size() != 1 || !equalsNoCase(codings.front(), "chunked")) {
      return refused(501, "Only the chunked transfer coding is understood.");
    }
    if (head.contentLength) {
      return refused(400, "The request gives both Content-Length and Transfer-Encoding.");
    }
    head.chunked = true;
  }
  if (head.http10 && !keepAlive) head.connectionClose = true;
  ParsedHead parsed;
  parsed.head = std::move(head);
  return parsed;
}

}  // namespace myriad::service::http

namespace myriad::service::http {

bool ChunkedFraming::feed(std::string_view bytes) {
  auto fail = [this] {
    state_ = State::Failed;
    return false;
  };
  for (size_t i = 0; i < bytes.size(); ++i) {
    const char c = bytes[i];
    const bool hex = std::isxdigit(static_cast<unsigned char>(c)) != 0;
    switch (state_) {
      case State::SizeLine:
        if (++lineBytes_ > kMaxSizeLine) return fail();
        if (!sizeEnded_ && hex) {
          // 15 hex digits: up to 2^60 bytes, far past any limit, and no overflow.
          if (++digits_ > 15) return fail();
          const int value = std::isdigit(static_cast<unsigned char>(c)) != 0
                                ? c - '0'
                                : std::tolower(static_cast<unsigned char>(c)) - 'a' + 10;
          size_ = size_ * 16 + static_cast<uint64_t>(value);
        } else if (c == '\r') {
          if (digits_ == 0) return fail();
          state_ = State::SizeLf;
        } else if (c == ';' && digits_ > 0) {
          sizeEnded_ = true;  // an extension, up to the CR
        } else if (!sizeEnded_ || c == '\n') {
          // Not "0x5", " 5" or "+5" (which httplib's strtoul would read as a size) and no bare
          // LF (which it would take as the line's end).
          return fail();
        }
        break;
      case State::SizeLf:
        if (c != '\n') return fail();
        state_ = size_ == 0 ? State::LastCr : State::Data;
        lineBytes_ = 0;
        digits_ = 0;
        sizeEnded_ = false;
        break;
      case State::Data: {
        const uint64_t take = std::min<uint64_t>(size_, bytes.size() - i);
        size_ -= take;
        i += take - 1;
        if (size_ == 0) state_ = State::DataCr;
        break;
      }
      case State::DataCr:
      case State::LastCr:
        if (c != '\r') return fail();
        state_ = state_ == State::DataCr ? State::DataLf : State::LastLf;
        break;
      case State::DataLf:
        if (c != '\n') return fail();
        state_ = State::SizeLine;
        break;
      case State::LastLf:
        // No trailer fields: httplib 0.11 takes none, so none is accepted here either.
        if (c != '\n') return fail();
        state_ = State::Done;
        overrun_ = bytes.size() - i - 1;
        return true;
      case State::Done:
        overrun_ = bytes.size() - i;
        return true;
      case State::Failed:
        return false;
    }
  }
  return state_ != State::Failed;
}

}  // namespace myriad::service::http
