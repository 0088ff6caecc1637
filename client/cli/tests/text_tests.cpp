// Server URLs, the one-line error text of problem responses, and number formatting.
#include <doctest/doctest.h>

#include "args.h"
#include "error_text.h"
#include "output.h"
#include "server_url.h"

using namespace myriad::cli;

TEST_CASE("server URLs") {
  ServerUrl a = parseServerUrl("http://127.0.0.1:8080", "--server");
  CHECK(a.scheme == "http");
  CHECK(a.host == "127.0.0.1");
  CHECK(a.port == 8080);
  CHECK(a.basePath == "");
  CHECK(a.origin() == "http://127.0.0.1:8080");

  ServerUrl b = parseServerUrl("https://example.org/myriad/", "--server");
  CHECK(b.port == 443);
  CHECK(b.basePath == "/myriad");
  CHECK(b.text() == "https://example.org:443/myriad");

  ServerUrl c = parseServerUrl("http://[::1]:9000", "MYRIAD_SERVER");
  CHECK(c.host == "::1");
  CHECK(c.origin() == "http://[::1]:9000");
  CHECK(parseServerUrl("http://localhost", "x").port == 80);

  for (const char* bad : {"127.0.0.1:8080", "ftp://h", "http://", "http://h:0", "http://h:65536",
                          "http://h:80x", "http://h:", "http://u@h", "http://h/?q", "http://[::1"}) {
    INFO(bad);
    try {
      parseServerUrl(bad, "MYRIAD_SERVER");
      FAIL("accepted");
    } catch (const UsageError& e) {
      CHECK(e.argument() == "MYRIAD_SERVER");
      CHECK(std::string(e.what()).find("is not a server URL") != std::string::npos);
    }
  }
}

TEST_CASE("percent-encoding of query values") {
  CHECK(percentEncode("spider.obj") == "spider.obj");
  CHECK(percentEncode("my model&x=1.glb") == "my%20model%26x%3D1.glb");
  CHECK(percentEncode("\xc3\xa9") == "%C3%A9");
}

TEST_CASE("a problem becomes '<detail> (<status> <type name>)'") {
  std::string body = R"({"type":"https://myriad.dev/problems/not-found","title":"Not found",)"
                     R"("status":404,"detail":"The session has no material 9999."})";
  CHECK(describeErrorResponse(404, "application/problem+json", body) ==
        "The session has no material 9999. (404 not-found)");

  std::string invalid = R"({"type":"https://myriad.dev/problems/invalid-body","title":"x",)"
                        R"("status":400,"detail":"eye equals\ntarget","pointer":"/eye"})";
  CHECK(describeErrorResponse(400, "application/problem+json; charset=utf-8", invalid) ==
        "eye equals target (400 invalid-body)");

  // Not a problem: the first line of the body and the reason phrase.
  CHECK(describeErrorResponse(502, "text/html", "<html>bad gateway\n<body>") ==
        "<html>bad gateway (502 Bad Gateway)");
  CHECK(describeErrorResponse(500, "", "") == "the server answered with an error (500 Internal "
                                              "Server Error)");
  CHECK(describeErrorResponse(400, "application/problem+json", "{not json") ==
        "{not json (400 Bad Request)");
  CHECK(describeErrorResponse(418, "text/plain", "teapot") == "teapot (418)");

  // An asset still in use: the server's detail and the problem's type.
  std::string conflict = R"({"type":"https://myriad.dev/problems/conflict","title":"Conflict",)"
                         R"("status":409,"detail":"Asset \"a-0123456789abcdef\" is in use: )"
                         R"(object 1 draws it (1 objects use it). Delete them first."})";
  CHECK(describeErrorResponse(409, "application/problem+json", conflict) ==
        "Asset \"a-0123456789abcdef\" is in use: object 1 draws it (1 objects use it). Delete "
        "them first. (409 conflict)");
  CHECK(describeErrorResponse(409, "text/plain", "busy") == "busy (409 Conflict)");
}

TEST_CASE("oneLine keeps an error on one line and short") {
  CHECK(oneLine("a\r\n\tb  c ") == "a b c");
  std::string longText(500, 'x');
  CHECK(oneLine(longText, 10) == "xxxxxxxxxx...");
  // A cut inside a UTF-8 sequence backs off to its start.
  CHECK(oneLine("ab\xc3\xa9", 3) == "ab...");
}

TEST_CASE("numbers for people") {
  CHECK(formatNumber(1.0) == "1");
  CHECK(formatNumber(0.1) == "0.1");
  CHECK(formatNumber(-0.0) == "0");
  CHECK(formatNumber(1234567.0) == "1.23457e+06");
  CHECK(formatVec({1, -2.5, 0.333333333}) == "1, -2.5, 0.333333");
  CHECK(formatBytes(512) == "512 B");
  CHECK(formatBytes(1536) == "1.5 KiB");
  CHECK(formatBytes(3u << 20) == "3.0 MiB");
}
