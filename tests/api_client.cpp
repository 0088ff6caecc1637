#include "api_client.h"

#include <doctest/doctest.h>

#include <cstring>

namespace myriad::test {
namespace {

// Model loads and frames on lavapipe with validation can take many seconds.
constexpr time_t kReadTimeoutSeconds = 300;

Reply toReply(const httplib::Result& result) {
  Reply reply;
  if (!result) return reply;
  reply.status = result->status;
  reply.body = result->body;
  reply.headers = result->headers;
  const std::string type = result->get_header_value("Content-Type");
  if (type.find("json") != std::string::npos) {
    reply.json = nlohmann::json::parse(reply.body, nullptr, false);
  }
  return reply;
}

httplib::Headers authorization(const std::string& token) {
  if (token.empty()) return {};
  return {{"Authorization", "Bearer " + token}};
}

}  // namespace

std::string Reply::header(const std::string& name) const {
  auto it = headers.find(name);
  return it == headers.end() ? std::string() : it->second;
}

ApiClient::ApiClient(const ServerProcess& server)
    : client_(std::make_unique<httplib::Client>(server.host(), server.port())) {
  client_->set_read_timeout(kReadTimeoutSeconds, 0);
  client_->set_write_timeout(60, 0);
  client_->set_connection_timeout(10, 0);
}

Reply ApiClient::get(const std::string& path, const std::string& token) {
  return toReply(client_->Get(path, authorization(token)));
}

Reply ApiClient::del(const std::string& path, const std::string& token) {
  return toReply(client_->Delete(path, authorization(token)));
}

Reply ApiClient::post(const std::string& path, const std::string& body, const std::string& token,
                      const std::string& contentType) {
  return toReply(client_->Post(path, authorization(token), body, contentType));
}

Reply ApiClient::put(const std::string& path, const std::string& body, const std::string& token,
                     const std::string& contentType) {
  return toReply(client_->Put(path, authorization(token), body, contentType));
}

Reply ApiClient::patch(const std::string& path, const std::string& body, const std::string& token,
                       const std::string& contentType) {
  return toReply(client_->Patch(path, authorization(token), body, contentType));
}

Reply ApiClient::send(const std::string& method, const std::string& path, const std::string& body,
                      const httplib::Headers& headers, const std::string& contentType) {
  httplib::Request req;
  req.method = method;
  req.path = path;
  req.headers = headers;
  req.body = body;
  if (!contentType.empty()) req.set_header("Content-Type", contentType);
  return toReply(client_->send(req));
}

TestSession createSession(ApiClient& api, const std::string& body, const std::string& apiKey) {
  Reply reply = api.post("/v1/sessions", body, apiKey);
  INFO("POST /v1/sessions: ", reply.body.substr(0, 400));
  REQUIRE(reply.status == 201);
  REQUIRE(reply.json.is_object());
  TestSession session;
  session.id = reply.json.at("id").get<std::string>();
  session.token = reply.json.at("token").get<std::string>();
  session.created = reply.json;
  return session;
}

std::string mintViewer(ApiClient& api, const TestSession& session, std::optional<int> ttlSeconds) {
  nlohmann::json body = {{"role", "viewer"}};
  if (ttlSeconds) body["ttlSeconds"] = *ttlSeconds;
  Reply minted = api.post(session.path() + "/tokens", body.dump(), session.token);
  REQUIRE(minted.status == 201);
  return minted.json.at("token").get<std::string>();
}

void checkProblem(const Reply& reply, int status, const std::string& typeName,
                  const std::string& context, std::optional<std::string> pointer,
                  std::optional<std::string> limit, std::optional<std::string> parameter) {
  INFO(context, " -> ", reply.status, " ", reply.body.substr(0, 400));
  REQUIRE(reply.status == status);
  CHECK(reply.header("Content-Type") == "application/problem+json");
  REQUIRE(reply.json.is_object());
  CHECK(reply.json.value("type", "") == "https://myriad.dev/problems/" + typeName);
  CHECK(reply.json.value("status", 0) == status);
  CHECK(!reply.json.value("title", "").empty());
  CHECK(!reply.json.value("detail", "").empty());
  if (pointer) CHECK(reply.json.value("pointer", "<none>") == *pointer);
  if (limit) CHECK(reply.json.value("limit", "<none>") == *limit);
  if (parameter) CHECK(reply.json.value("parameter", "<none>") == *parameter);
  if (status == 429) CHECK(!reply.header("Retry-After").empty());
}

ChunkParser<StreamPart> multipartParser() {
  static constexpr std::string_view kOpening = "--myriad-frame\r\n";
  static constexpr std::string_view kClosing = "\r\n--myriad-frame\r\n";
  return [opened = false](std::string_view bytes, std::vector<StreamPart>& out) mutable -> size_t {
    size_t used = 0;
    if (!opened) {
      if (bytes.size() < kOpening.size()) return 0;
      if (bytes.substr(0, kOpening.size()) != kOpening) {
        throw FramingError("the body does not start with the boundary line");
      }
      opened = true;
      used = kOpening.size();
    }
    const size_t headerEnd = bytes.find("\r\n\r\n", used);
    if (headerEnd == std::string_view::npos) return used;
    StreamPart part;
    for (size_t line = used; line < headerEnd;) {
      const size_t end = bytes.find("\r\n", line);
      const std::string_view text = bytes.substr(line, end - line);
      const size_t colon = text.find(": ");
      if (colon == std::string_view::npos) {
        throw FramingError("malformed part header line: " + std::string(text));
      }
      part.headers[std::string(text.substr(0, colon))] = std::string(text.substr(colon + 2));
      line = end + 2;
    }
    if (!part.headers.count("Content-Length")) throw FramingError("a part without Content-Length");
    const size_t length = std::stoul(part.headers["Content-Length"]);
    const size_t bodyStart = headerEnd + 4;
    if (bytes.size() < bodyStart + length + kClosing.size()) return used;
    if (bytes.substr(bodyStart + length, kClosing.size()) != kClosing) {
      throw FramingError("Content-Length does not end where the boundary starts");
    }
    part.body = std::string(bytes.substr(bodyStart, length));
    part.arrived = StreamClock::now();
    out.push_back(std::move(part));
    return bodyStart + length + kClosing.size();
  };
}

ChunkParser<VideoChunk> videoChunkParser() {
  constexpr size_t kHeaderBytes = 48;
  return [](std::string_view bytes, std::vector<VideoChunk>& out) -> size_t {
    if (bytes.size() < kHeaderBytes) return 0;
    auto read = [&]<typename T>(T& value, size_t offset) {
      std::memcpy(&value, bytes.data() + offset, sizeof value);
    };
    uint32_t payload = 0;
    read(payload, 0);
    if (bytes.size() < kHeaderBytes + payload) return 0;
    VideoChunk chunk;
    read(chunk.kind, 4);
    read(chunk.width, 8);
    read(chunk.height, 10);
    read(chunk.sequence, 12);
    read(chunk.timestampUs, 16);
    read(chunk.version, 24);
    read(chunk.time, 32);
    read(chunk.encodeUs, 40);
    uint32_t reserved = 0;
    read(reserved, 44);
    if (bytes[5] != 0 || bytes[6] != 0 || bytes[7] != 0 || reserved != 0) {
      throw FramingError("reserved header bytes are not zero");
    }
    chunk.payload = std::string(bytes.substr(kHeaderBytes, payload));
    chunk.arrived = StreamClock::now();
    out.push_back(std::move(chunk));
    return kHeaderBytes + payload;
  };
}

uint64_t validationMessages(ApiClient& api) {
  Reply info = api.get("/v1/info");
  REQUIRE(info.status == 200);
  return info.json.at("validation").at("messages").get<uint64_t>();
}

}  // namespace myriad::test
