#include "session_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace myriad::cli {
namespace {

std::string trim(const std::string& text) {
  size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  size_t end = text.find_last_not_of(" \t\r\n");
  return text.substr(begin, end - begin + 1);
}

std::string systemError(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

// mkdir -p with mode 0700 for the directories it creates.
void makeDirectories(const std::string& dir) {
  if (dir.empty()) return;
  struct stat st{};
  if (stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) throw std::runtime_error(dir + " is not a directory");
    return;
  }
  size_t slash = dir.rfind('/');
  if (slash != std::string::npos && slash > 0) makeDirectories(dir.substr(0, slash));
  if (mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
    throw std::runtime_error(systemError("cannot create the directory", dir));
  }
}

}  // namespace

std::optional<std::pair<std::string, std::string>> parseSessionText(const std::string& text) {
  std::string line = trim(text);
  size_t colon = line.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == line.size()) return std::nullopt;
  std::string id = line.substr(0, colon);
  std::string token = line.substr(colon + 1);
  auto plain = [](const std::string& s) {
    return s.find_first_of(" \t\r\n:/?#%") == std::string::npos;
  };
  if (!plain(id) || !plain(token)) return std::nullopt;
  return std::make_pair(id, token);
}

std::string defaultSessionPath(const char* xdgStateHome, const char* home) {
  // XDG: a relative $XDG_STATE_HOME is invalid and must be ignored.
  if (xdgStateHome != nullptr && xdgStateHome[0] == '/') {
    return std::string(xdgStateHome) + "/myriad/session";
  }
  if (home != nullptr && home[0] != '\0') return std::string(home) + "/.local/state/myriad/session";
  throw std::runtime_error(
      "neither XDG_STATE_HOME nor HOME is set, so there is no default session file; "
      "give --session-file PATH");
}

std::string sessionFilePath(const GlobalOptions& global) {
  if (global.sessionFile) return *global.sessionFile;
  return defaultSessionPath(std::getenv("XDG_STATE_HOME"), std::getenv("HOME"));
}

SessionRef findSession(const GlobalOptions& global) {
  if (const char* env = std::getenv("MYRIAD_SESSION"); env != nullptr && env[0] != '\0') {
    auto parsed = parseSessionText(env);
    if (!parsed) {
      throw std::runtime_error("MYRIAD_SESSION is not of the form id:token");
    }
    return {parsed->first, parsed->second, "MYRIAD_SESSION", false};
  }
  std::string path = sessionFilePath(global);
  std::optional<SessionRef> session = readSessionFile(path);
  if (!session) {
    throw std::runtime_error("no session yet (no " + path +
                             "): run `myriad session new` first, or set MYRIAD_SESSION");
  }
  return *session;
}

std::optional<SessionRef> readSessionFile(const std::string& path) {
  struct stat st{};
  if (stat(path.c_str(), &st) != 0 && errno == ENOENT) return std::nullopt;
  std::ifstream file(path);
  if (!file) throw std::runtime_error(systemError("cannot read the session file", path));
  std::stringstream text;
  text << file.rdbuf();
  auto parsed = parseSessionText(text.str());
  if (!parsed) {
    throw std::runtime_error("the session file " + path +
                             " does not hold id:token; run `myriad session new` again");
  }
  return SessionRef{parsed->first, parsed->second, path, true};
}

void saveSession(const std::string& path, const std::string& id, const std::string& token) {
  size_t slash = path.rfind('/');
  if (slash != std::string::npos && slash > 0) makeDirectories(path.substr(0, slash));
  // Written beside the target and renamed over it, so a reader never sees half a token, and
  // created 0600 from the start so the token is never readable by others, even briefly.
  std::string temporary = path + ".tmp-" + std::to_string(getpid());
  int fd = open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(systemError("cannot write the session file", temporary));
  std::string line = id + ":" + token + "\n";
  bool ok = fchmod(fd, 0600) == 0 && write(fd, line.data(), line.size()) == ssize_t(line.size());
  ok = (close(fd) == 0) && ok;
  if (!ok || rename(temporary.c_str(), path.c_str()) != 0) {
    std::string message = systemError("cannot write the session file", path);
    unlink(temporary.c_str());
    throw std::runtime_error(message);
  }
}

bool removeSessionFile(const std::string& path) {
  if (unlink(path.c_str()) == 0) return true;
  if (errno == ENOENT) return false;
  throw std::runtime_error(systemError("cannot remove the session file", path));
}

}  // namespace myriad::cli
