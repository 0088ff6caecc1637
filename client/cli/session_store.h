// Where `myriad` keeps the current session's id:token. MYRIAD_SESSION=id:token wins; else the
// session file: --session-file, or $XDG_STATE_HOME/myriad/session, or
// ~/.local/state/myriad/session (XDG's default state directory). The file holds one line
// "id:token" and is written with mode 0600: the token is the session's only credential.
#pragma once

#include <optional>
#include <string>

#include "args.h"

namespace myriad::cli {

struct SessionRef {
  std::string id;
  std::string token;
  std::string origin;  // "MYRIAD_SESSION" or the file's path, for messages
  bool fromFile = false;
};

// "id:token" (surrounding white space ignored) -> {id, token}; nullopt when malformed.
std::optional<std::pair<std::string, std::string>> parseSessionText(const std::string& text);

// The session file's path when --session-file is not given. Pure: the caller passes the
// environment's values (null when unset). Throws std::runtime_error when neither is usable.
std::string defaultSessionPath(const char* xdgStateHome, const char* home);

// --session-file, or the default from the environment.
std::string sessionFilePath(const GlobalOptions& global);

// The session to use. Throws std::runtime_error with one sentence when there is none or it is
// malformed.
SessionRef findSession(const GlobalOptions& global);

// The session in the file at `path`; nullopt when there is no such file. Throws
// std::runtime_error when it cannot be read or does not hold id:token.
std::optional<SessionRef> readSessionFile(const std::string& path);

// Writes "id:token\n" to `path` with mode 0600 (directories created 0700), replacing it
// atomically. Throws std::runtime_error.
void saveSession(const std::string& path, const std::string& id, const std::string& token);

// Deletes the file; false when it did not exist. Throws std::runtime_error on other failures.
bool removeSessionFile(const std::string& path);

}  // namespace myriad::cli
