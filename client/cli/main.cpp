// myriad: the command-line client of myriad-server. Exit status 0 done, 1 the server refused or
// could not be reached (one line on stderr), 2 bad usage (the offending argument named).
#include <csignal>
#include <cstdlib>
#include <iostream>

#include "args.h"
#include "commands.h"
#include "error_text.h"
#include "http.h"
#include "server_url.h"

namespace {

using namespace myriad::cli;

int usageFailure(const UsageError& e) {
  std::string hint = e.command().empty() ? "see myriad --help"
                                         : "see myriad " + e.command() + " --help";
  std::cerr << "myriad: " << oneLine(e.what()) << " (" << hint << ")\n";
  return 2;
}

ServerUrl serverUrl(const GlobalOptions& global) {
  if (global.server) return parseServerUrl(*global.server, "--server");
  if (const char* env = std::getenv("MYRIAD_SERVER"); env != nullptr && env[0] != '\0') {
    return parseServerUrl(env, "MYRIAD_SERVER");
  }
  return parseServerUrl(kDefaultServer, "the default server");
}

}  // namespace

int main(int argc, char** argv) {
  // A server that refuses an upload closes the connection mid-body; the write must fail with
  // EPIPE (reported as one line) rather than kill the process.
  std::signal(SIGPIPE, SIG_IGN);
  std::vector<std::string> args(argv + 1, argv + argc);
  Invocation inv;
  ServerUrl url;
  try {
    inv = parseArguments(args);
    if (inv.version) {
      std::cout << "myriad " << MYRIAD_VERSION << " (protocol v1)\n";
      return 0;
    }
    if (inv.help) {
      std::cout << (inv.command != nullptr ? commandHelp(*inv.command) : overviewHelp());
      return 0;
    }
    url = serverUrl(inv.global);
  } catch (const UsageError& e) {
    return usageFailure(e);
  }

  try {
    HttpClient http(url);
    http.setIfMatch(inv.global.ifMatch);
    Context ctx(inv, http, std::cout, std::cerr);
    int status = runCommand(ctx);
    std::cout.flush();
    return status;
  } catch (const UsageError& e) {
    return usageFailure(e);
  } catch (const nlohmann::json::exception& e) {
    std::cerr << "myriad: the server's answer does not match protocol v1 (" << oneLine(e.what())
              << "); try --json to see it\n";
  } catch (const std::exception& e) {
    std::cerr << "myriad: " << oneLine(e.what()) << "\n";
  }
  return 1;
}
