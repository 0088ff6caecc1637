// The multipart/x-mixed-replace reader on the stream's own framing, split at every byte.
#include <doctest/doctest.h>

#include <stdexcept>

#include "multipart.h"

using namespace myriad::cli;

namespace {

std::string part(const std::string& body, int seq, bool withLength = true) {
  std::string text = "--myriad-frame\r\nContent-Type: image/jpeg\r\n";
  if (withLength) text += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  text += "X-Myriad-Frame: " + std::to_string(seq) + "\r\n\r\n" + body + "\r\n";
  return text;
}

}  // namespace

TEST_CASE("boundary from Content-Type") {
  CHECK(multipartBoundary("multipart/x-mixed-replace; boundary=myriad-frame") == "myriad-frame");
  CHECK(multipartBoundary("multipart/x-mixed-replace;boundary=\"a b\"; x=1") == "a b");
  CHECK(multipartBoundary("Multipart/X-Mixed-Replace; Boundary=abc;") == "abc");
  CHECK_FALSE(multipartBoundary("image/jpeg").has_value());
  CHECK_FALSE(multipartBoundary("multipart/x-mixed-replace").has_value());
}

TEST_CASE("parts with Content-Length, bodies containing the boundary and CRLFs") {
  // A JPEG may contain any bytes, even the delimiter: Content-Length must win.
  std::string tricky = std::string("\xff\xd8\r\n--myriad-frame\r\n\0\x01", 22) + "\xff\xd9";
  std::string stream = part("first", 1) + part(tricky, 2) + part("third", 3);

  MultipartReader whole("myriad-frame");
  std::vector<MultipartPart> parts = whole.feed(stream);
  REQUIRE(parts.size() == 3);
  CHECK(parts[0].body == "first");
  CHECK(parts[1].body == tricky);
  CHECK(parts[2].body == "third");
  CHECK(parts[1].headers.at("x-myriad-frame") == "2");
  CHECK(parts[0].headers.at("content-type") == "image/jpeg");

  // The same bytes one at a time give the same parts.
  MultipartReader byteWise("myriad-frame");
  std::vector<MultipartPart> collected;
  for (char c : stream) {
    for (auto& p : byteWise.feed(std::string_view(&c, 1))) collected.push_back(std::move(p));
  }
  REQUIRE(collected.size() == 3);
  CHECK(collected[1].body == tricky);
}

TEST_CASE("parts without Content-Length end at the next delimiter; the close ends the stream") {
  MultipartReader reader("b");
  std::string text = "preamble\r\n--b\r\n\r\nalpha\r\n--b\r\nX-A: 1\r\n\r\nbeta\r\n--b--\r\n";
  std::vector<MultipartPart> parts = reader.feed(text);
  REQUIRE(parts.size() == 2);
  CHECK(parts[0].body == "alpha");
  CHECK(parts[1].body == "beta");
  CHECK(parts[1].headers.at("x-a") == "1");
  CHECK(reader.finished());
}

TEST_CASE("the stream's own layout: next boundary written right after each part") {
  MultipartReader reader("myriad-frame");
  // Part 1 complete, then the next boundary line only (the server sends it at once).
  std::string first = part("one", 1) + "--myriad-frame\r\n";
  auto parts = reader.feed(first);
  REQUIRE(parts.size() == 1);
  CHECK(parts[0].body == "one");
  parts = reader.feed("Content-Type: image/jpeg\r\nContent-Length: 3\r\n\r\ntwo\r\n");
  REQUIRE(parts.size() == 1);
  CHECK(parts[0].body == "two");
}

TEST_CASE("malformed parts are errors") {
  MultipartReader badHeader("b");
  CHECK_THROWS_AS(badHeader.feed("--b\r\nno colon here\r\n\r\n"), std::runtime_error);
  MultipartReader badLength("b");
  CHECK_THROWS_AS(badLength.feed("--b\r\nContent-Length: -5\r\n\r\n"), std::runtime_error);
  MultipartReader hugeHeader("b");
  CHECK_THROWS_AS(hugeHeader.feed("--b\r\n" + std::string(70000, 'x')), std::runtime_error);
}
