// session new | show | delete.
#include <cstdlib>

#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

void printSessionState(std::ostream& out, const protocol::SessionState& s) {
  const protocol::ModelSummary& m = s.model;
  const protocol::Camera& c = s.camera;
  const protocol::Settings& st = s.settings;
  printFields(out, {
      {"session", s.id},
      {"model", m.source + " (" + std::to_string(m.meshes) + " meshes, " +
                    std::to_string(m.instances) + " instances, " + std::to_string(m.materials) +
                    " materials)"},
      {"bounds", "min " + formatVec(m.bounds.min) + "  max " + formatVec(m.bounds.max)},
      {"camera", "eye " + formatVec(c.eye) + "  target " + formatVec(c.target) + "  fov " +
                     formatNumber(c.fovY)},
      {"technique", st.technique},
      {"lights", std::to_string(s.lightCount) + (st.animate ? " (animated)" : "")},
      {"expires", "after " + std::to_string(s.expiresInSeconds) + " s without requests"},
  });
}

int sessionNew(Context& ctx) {
  const Invocation& inv = ctx.inv;
  std::optional<std::string> apiKey = inv.find<std::string>("api-key");
  if (!apiKey) {
    if (const char* env = std::getenv("MYRIAD_API_KEY"); env != nullptr && env[0] != '\0') {
      apiKey = env;
    }
  }
  if (apiKey) ctx.http.setBearer(*apiKey);

  std::string raw;
  nlohmann::json answer = ctx.http.sendJson("POST", std::string(protocol::routes::kSessions),
                                            protocol::SessionCreate{}, {}, &raw);
  auto created = answer.get<protocol::SessionCreated>();
  if (inv.has("print-env")) {
    ctx.out << "export MYRIAD_SESSION=" << created.id << ":" << created.token << "\n";
    return 0;
  }
  std::string path = sessionFilePath(inv.global);
  std::optional<std::string> previous;
  try {
    if (auto old = readSessionFile(path)) previous = old->id;
  } catch (const std::exception&) {
    // No readable previous session: nothing to mention.
  }
  saveSession(path, created.id, created.token);
  if (previous) {
    ctx.err << "myriad: note: " << path << " held session " << *previous
            << ", which stays open on the server until it idles out (or `myriad session delete` "
               "it with MYRIAD_SESSION)\n";
  }
  if (ctx.json()) {
    printRaw(ctx.out, raw);
  } else {
    ctx.out << "session " << created.id << " created (ends after " << created.expiresInSeconds
            << " s without requests); id:token saved to " << path << "\n";
  }
  if (const char* env = std::getenv("MYRIAD_SESSION"); env != nullptr && env[0] != '\0') {
    ctx.err << "myriad: note: MYRIAD_SESSION is set and wins over " << path
            << "; unset it to use the new session\n";
  }
  return 0;
}

int sessionShow(Context& ctx) {
  nlohmann::json state = ctx.call("GET", ctx.sessionRoute(protocol::routes::kSession));
  if (!ctx.json()) printSessionState(ctx.out, state.get<protocol::SessionState>());
  return 0;
}

int sessionDelete(Context& ctx) {
  const SessionRef session = ctx.session();
  auto forget = [&] {
    if (session.fromFile) removeSessionFile(session.origin);
  };
  try {
    ctx.call("DELETE", ctx.sessionRoute(protocol::routes::kSession));
  } catch (const ApiError& e) {
    // An expired session is gone on the server already; the file pointing at it is useless.
    if (e.status() == 404) forget();
    throw;
  }
  forget();
  if (!ctx.json()) {
    ctx.out << "session " << session.id << " deleted";
    if (session.fromFile) ctx.out << "; removed " << session.origin;
    ctx.out << "\n";
  }
  if (!session.fromFile) ctx.err << "myriad: note: unset MYRIAD_SESSION too\n";
  return 0;
}

// The web client's address for the session with `token` (the page reads #session=&token=).
std::string pageLink(Context& ctx, const std::string& id, const std::string& token) {
  return ctx.http.url().text() + std::string(protocol::routes::kWebRoot) + "#session=" + id +
         "&token=" + token;
}

int sessionShare(Context& ctx) {
  protocol::TokenCreate request;
  request.role = std::string(protocol::roles::kViewer);
  if (auto ttl = ctx.inv.find<uint64_t>("ttl")) request.ttlSeconds = *ttl;
  nlohmann::json answer =
      ctx.call("POST", ctx.sessionRoute(protocol::routes::kSessionTokens), request);
  if (ctx.json()) return 0;
  const auto created = answer.get<protocol::TokenCreated>();
  printFields(ctx.out, {{"session", ctx.session().id},
                        {"role", created.role + " (reads and watches; changes are refused)"},
                        {"expires", "in " + std::to_string(created.expiresInSeconds) + " s"},
                        {"token", created.token},
                        {"link", pageLink(ctx, ctx.session().id, created.token)}});
  return 0;
}

int sessionUnshare(Context& ctx) {
  ctx.call("DELETE", ctx.sessionRoute(protocol::routes::kSessionTokens));
  if (!ctx.json()) ctx.out << "revoked every view-only token of session " << ctx.session().id << "\n";
  return 0;
}

}  // namespace

int runSessionCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "open") {
    const SessionRef& session = ctx.session();
    ctx.out << pageLink(ctx, session.id, session.token) << "\n";
    return 0;
  }
  if (name == "session share") return sessionShare(ctx);
  if (name == "session unshare") return sessionUnshare(ctx);
  if (name == "session new") return sessionNew(ctx);
  if (name == "session show") return sessionShow(ctx);
  return sessionDelete(ctx);
}

}  // namespace myriad::cli
