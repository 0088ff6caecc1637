// A small JSON client of the session API for the api tests (api_tests.cpp, api_frames_tests.cpp):
// requests with a session's bearer token, answers parsed, problems checked in one call.
#pragma once

#include <httplib.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "server_process.h"

namespace myriad::test {

struct Reply {
  int status = 0;  // 0 when the request failed (no connection, timeout)
  std::string body;
  httplib::Headers headers;
  nlohmann::json json;  // the body parsed when it is JSON, else null

  std::string header(const std::string& name) const;
};

class ApiClient {
 public:
  explicit ApiClient(const ServerProcess& server);

  // `token`: sent as Authorization: Bearer <token> when not empty.
  Reply get(const std::string& path, const std::string& token = "");
  Reply del(const std::string& path, const std::string& token = "");
  // JSON bodies; `body` as text so tests can send what is not valid JSON.
  Reply post(const std::string& path, const std::string& body, const std::string& token = "",
             const std::string& contentType = "application/json");
  Reply put(const std::string& path, const std::string& body, const std::string& token = "",
            const std::string& contentType = "application/json");
  Reply patch(const std::string& path, const std::string& body, const std::string& token = "",
              const std::string& contentType = "application/json");
  // Any method with any headers.
  Reply send(const std::string& method, const std::string& path, const std::string& body,
             const httplib::Headers& headers, const std::string& contentType = "");

  httplib::Client& raw() { return *client_; }

 private:
  std::unique_ptr<httplib::Client> client_;
};

struct TestSession {
  std::string id;
  std::string token;
  nlohmann::json created;  // the 201 body
  std::string path() const { return "/v1/sessions/" + id; }
};

// POST /v1/sessions with `body`; REQUIREs 201.
TestSession createSession(ApiClient& api, const std::string& body = "{}",
                          const std::string& apiKey = "");

// A viewer token of `session` (POST .../tokens), valid for `ttlSeconds` or the server's default;
// REQUIREs the 201.
std::string mintViewer(ApiClient& api, const TestSession& session,
                       std::optional<int> ttlSeconds = std::nullopt);

// CHECKs a problem response: status, content type, type name (the last segment of the type URI),
// and, when given, `pointer`, `parameter` and `limit`.
void checkProblem(const Reply& reply, int status, const std::string& typeName,
                  const std::string& context, std::optional<std::string> pointer = std::nullopt,
                  std::optional<std::string> limit = std::nullopt,
                  std::optional<std::string> parameter = std::nullopt);

// GET /v1/info's validation message count (REQUIREs the request to work).
uint64_t validationMessages(ApiClient& api);

// ---- Streamed bodies (GET .../stream): one reader, a parser per format.

using StreamClock = std::chrono::steady_clock;

// A part of a multipart/x-mixed-replace stream.
struct StreamPart {
  std::map<std::string, std::string> headers;
  std::string body;
  StreamClock::time_point arrived;
};

// A chunk of a video stream (protocol::video_chunk's 48-byte header, then the payload).
struct VideoChunk {
  uint8_t kind = 0;  // 1 key, 2 delta, 3 keep-alive
  uint16_t width = 0, height = 0;
  uint32_t sequence = 0;
  uint64_t timestampUs = 0;
  uint64_t version = 0;
  double time = 0.0;
  uint32_t encodeUs = 0;
  std::string payload;
  StreamClock::time_point arrived;
};

// Thrown by a parser for bytes that break its format: the reader keeps the message
// (framingError()) and parses no further.
class FramingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Splits whole items off the front of `bytes` (the body's bytes not used yet) into `out` and
// returns how many bytes it used (0: it needs more). Called under the reader's lock, in order.
template <typename Item>
using ChunkParser = std::function<size_t(std::string_view bytes, std::vector<Item>& out)>;

// The exact framing of protocol/CONTRACT.md: "--myriad-frame\r\n" once, then per part the
// headers, the Content-Length bytes, "\r\n--myriad-frame\r\n".
ChunkParser<StreamPart> multipartParser();
// protocol::video_chunk's framing; FramingError when reserved header bytes are not zero.
ChunkParser<VideoChunk> videoChunkParser();

// Reads a streamed response body on a thread of its own: each read is appended under a lock,
// split by the format's parser, and waiters are notified. Stops reading when destroyed.
template <typename Item>
class ChunkReader {
 public:
  ChunkReader(const ServerProcess& server, std::string path, httplib::Headers headers,
              ChunkParser<Item> parser)
      : client_(server.host(), server.port()), parser_(std::move(parser)) {
    client_.set_read_timeout(kReadTimeoutSeconds, 0);
    client_.set_connection_timeout(10, 0);
    thread_ = std::thread([this, path = std::move(path), headers = std::move(headers)] {
      httplib::Result res = client_.Get(
          path, headers,
          [this](const httplib::Response& response) {
            std::lock_guard lock(mutex_);
            status_ = response.status;
            headers_ = response.headers;
            changed_.notify_all();
            return true;
          },
          [this](const char* data, size_t size) {
            std::lock_guard lock(mutex_);
            buffer_.append(data, size);
            parse();
            changed_.notify_all();
            return !stop_;
          });
      std::lock_guard lock(mutex_);
      if (res && status_ == 0) status_ = res->status;
      if (res && status_ >= 400) errorBody_ = res->body;
      ended_ = true;
      changed_.notify_all();
    });
  }
  ~ChunkReader() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    client_.stop();
    thread_.join();
  }
  ChunkReader(const ChunkReader&) = delete;
  ChunkReader& operator=(const ChunkReader&) = delete;

  // The items so far once `done(items)` holds (or the body ended, or the timeout passed).
  std::vector<Item> waitUntil(const std::function<bool(const std::vector<Item>&)>& done,
                              std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return done(items_) || ended_; });
    return items_;
  }
  // The items so far once there are `count`.
  std::vector<Item> waitFor(size_t count, std::chrono::seconds timeout) {
    return waitUntil([count](const std::vector<Item>& items) { return items.size() >= count; },
                     timeout);
  }
  bool waitForEnd(std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return ended_; });
  }
  std::vector<Item> items() {
    std::lock_guard lock(mutex_);
    return items_;
  }
  // The response status, once the headers arrived (0: the request failed).
  int status() {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, std::chrono::seconds(kReadTimeoutSeconds),
                      [&] { return status_ != 0 || ended_; });
    return status_;
  }
  std::string header(const std::string& name) {
    std::lock_guard lock(mutex_);
    auto it = headers_.find(name);
    return it == headers_.end() ? std::string() : it->second;
  }
  std::string framingError() {
    std::lock_guard lock(mutex_);
    return framingError_;
  }
  std::string errorBody() {
    std::lock_guard lock(mutex_);
    return errorBody_;
  }
  // Bytes after the last whole item (a stream that ends cleanly leaves none).
  size_t leftover() {
    std::lock_guard lock(mutex_);
    return buffer_.size() - consumed_;
  }

 private:
  static constexpr time_t kReadTimeoutSeconds = 300;  // frames on lavapipe with validation

  void parse() {  // mutex_ held
    while (framingError_.empty()) {
      size_t used = 0;
      try {
        used = parser_(std::string_view(buffer_).substr(consumed_), items_);
      } catch (const FramingError& e) {
        framingError_ = e.what();
      }
      if (used == 0) break;
      consumed_ += used;
    }
    if (consumed_ > (size_t(1) << 20) && consumed_ == buffer_.size()) {
      buffer_.clear();  // bounded: a long stream's used bytes go
      consumed_ = 0;
    }
  }

  httplib::Client client_;
  ChunkParser<Item> parser_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::string buffer_;
  size_t consumed_ = 0;
  std::vector<Item> items_;
  httplib::Headers headers_;
  std::string framingError_;
  std::string errorBody_;
  int status_ = 0;
  bool ended_ = false;
  bool stop_ = false;
};

class MultipartReader : public ChunkReader<StreamPart> {
 public:
  MultipartReader(const ServerProcess& server, std::string path, httplib::Headers headers = {})
      : ChunkReader(server, std::move(path), std::move(headers), multipartParser()) {}
};

class VideoReader : public ChunkReader<VideoChunk> {
 public:
  VideoReader(const ServerProcess& server, std::string path, httplib::Headers headers = {})
      : ChunkReader(server, std::move(path), std::move(headers), videoChunkParser()) {}
};

// Authorization: Bearer `token`.
inline httplib::Headers bearer(const std::string& token) {
  return {{"Authorization", "Bearer " + token}};
}

}  // namespace myriad::test
