#include "http.h"

#include <httplib.h>
#include <strings.h>

#include <exception>

#include "error_text.h"
#include "protocol/constants.h"

namespace myriad::cli {
namespace {

// Frames on a CPU renderer (lavapipe) with validation take seconds; uploads can be large.
constexpr time_t kConnectSeconds = 10;
constexpr time_t kReadSeconds = 300;
constexpr time_t kWriteSeconds = 300;

HttpResponse toResponse(const httplib::Response& res) {
  HttpResponse out;
  out.status = res.status;
  for (const auto& [name, value] : res.headers) out.headers.emplace_back(name, value);
  out.body = res.body;
  return out;
}

}  // namespace

std::string HttpResponse::header(const std::string& name) const {
  for (const auto& [key, value] : headers) {
    if (strcasecmp(key.c_str(), name.c_str()) == 0) return value;
  }
  return "";
}

HttpClient::HttpClient(ServerUrl url)
    : url_(std::move(url)), client_(std::make_unique<httplib::Client>(url_.origin())) {
  client_->set_connection_timeout(kConnectSeconds, 0);
  client_->set_read_timeout(kReadSeconds, 0);
  client_->set_write_timeout(kWriteSeconds, 0);
  client_->set_keep_alive(true);  // one connection for the few requests a command makes
  // A request's headers and body leave as separate writes: without this the body waits for the
  // server's delayed ACK (40 ms) on every request after the connection's first.
  client_->set_tcp_nodelay(true);
}

HttpClient::~HttpClient() = default;

std::string HttpClient::target(const std::string& path, const Query& query) const {
  std::string out = url_.basePath + path;
  char separator = '?';
  for (const auto& [name, value] : query) {
    out += separator + percentEncode(name) + "=" + percentEncode(value);
    separator = '&';
  }
  return out;
}

void HttpClient::failTransport(int error) const {
  auto e = static_cast<httplib::Error>(error);
  switch (e) {
    case httplib::Error::Connection:
    case httplib::Error::ConnectionTimeout:
      throw ApiError("cannot connect to a Myriad server at " + url_.text() +
                     ": is myriad-server running there? (set --server or MYRIAD_SERVER)");
    case httplib::Error::Read:
      throw ApiError("the server at " + url_.text() +
                     " closed the connection or sent nothing for " + std::to_string(kReadSeconds) +
                     " s");
    case httplib::Error::Write:
      throw ApiError("the connection to " + url_.text() + " broke while sending the request");
    case httplib::Error::SSLConnection:
    case httplib::Error::SSLLoadingCerts:
    case httplib::Error::SSLServerVerification:
      throw ApiError("TLS with " + url_.text() + " failed (" + httplib::to_string(e) +
                     "); myriad-server itself speaks plain http");
    default:
      throw ApiError("request to " + url_.text() + " failed: " + httplib::to_string(e));
  }
}

void HttpClient::addBearer(httplib::Request& req) const {
  if (!bearer_) return;
  req.headers.emplace(std::string(protocol::headers::kAuthorization),
                      std::string(protocol::headers::kBearerPrefix) + *bearer_);
}

HttpResponse HttpClient::send(const std::string& method, const std::string& path,
                              const Query& query, const std::string& body,
                              const std::string& contentType) {
  httplib::Request req;
  req.method = method;
  req.path = target(path, query);
  addBearer(req);
  req.headers.emplace("Accept", std::string(protocol::kJsonContentType) + ", " +
                                    std::string(protocol::kProblemContentType) + ", */*");
  if (ifMatch_ && method != "GET") req.headers.emplace(protocol::headers::kIfMatch, *ifMatch_);
  if (!contentType.empty()) {
    req.headers.emplace("Content-Type", contentType);
    req.body = body;
  }
  httplib::Result result = client_->send(req);
  if (!result) failTransport(int(result.error()));
  HttpResponse response = toResponse(result.value());
  if (std::string tag = response.header(std::string(protocol::headers::kETag)); !tag.empty()) {
    lastETag_ = std::move(tag);
  }
  return response;
}

HttpResponse HttpClient::sendOk(const std::string& method, const std::string& path,
                                const Query& query, const std::string& body,
                                const std::string& contentType) {
  HttpResponse res = send(method, path, query, body, contentType);
  if (res.status >= 400) {
    throw ApiError(describeErrorResponse(res.status, res.header("Content-Type"), res.body),
                   res.status);
  }
  return res;
}

nlohmann::json HttpClient::sendJson(const std::string& method, const std::string& path,
                                    const nlohmann::json& body, const Query& query,
                                    std::string* raw) {
  HttpResponse res = body.is_null() ? sendOk(method, path, query)
                                    : sendOk(method, path, query, body.dump(),
                                             std::string(protocol::kJsonContentType));
  if (raw != nullptr) *raw = res.body;
  if (res.status == 204 || res.body.empty()) return nullptr;
  nlohmann::json parsed = nlohmann::json::parse(res.body, nullptr, false);
  if (parsed.is_discarded()) {
    throw ApiError("the server's answer to " + method + " " + path + " is not JSON (" +
                   std::to_string(res.status) + ")", res.status);
  }
  return parsed;
}

void HttpClient::stream(const std::string& path, const Query& query,
                        const std::function<bool(const HttpResponse& head)>& onHead,
                        const std::function<bool(const char* data, size_t size)>& onData) {
  httplib::Request req;
  req.method = "GET";
  req.path = target(path, query);
  addBearer(req);

  HttpResponse head;
  std::string errorBody;
  bool failed = false;
  bool stoppedByUs = false;
  // An exception must not unwind through cpp-httplib's read loop: it is kept, the transfer is
  // stopped, and it is thrown again once send() has returned.
  std::exception_ptr callbackError;
  auto guarded = [&](const std::function<bool()>& call) {
    try {
      if (call()) return true;
    } catch (...) {
      callbackError = std::current_exception();
    }
    stoppedByUs = true;
    return false;
  };
  req.response_handler = [&](const httplib::Response& res) {
    head = toResponse(res);
    if (res.status >= 400) {
      failed = true;  // keep reading: the problem's body follows
      return true;
    }
    return guarded([&] { return onHead(head); });
  };
  req.content_receiver = [&](const char* data, size_t size, uint64_t, uint64_t) {
    if (failed) {
      if (errorBody.size() < 64 * 1024) errorBody.append(data, size);
      return true;
    }
    return guarded([&] { return onData(data, size); });
  };
  httplib::Result result = client_->send(req);
  if (callbackError) std::rethrow_exception(callbackError);
  if (failed) {
    throw ApiError(describeErrorResponse(head.status, head.header("Content-Type"), errorBody),
                   head.status);
  }
  if (!result && !(stoppedByUs && result.error() == httplib::Error::Canceled)) {
    failTransport(int(result.error()));
  }
}

}  // namespace myriad::cli
