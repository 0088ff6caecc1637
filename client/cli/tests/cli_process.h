// Runs the real `myriad` binary as a user would: arguments, extra environment, standard output
// and error captured, exit status returned.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace myriad::test {

struct CliResult {
  int exitCode = -1;  // -1 when killed by a signal
  std::string out;
  std::string err;
};

// Spawns MYRIAD_CLI_PATH with `args`; `env` entries are added to (or replace in) this process's
// environment; an empty value removes the variable. Waits for the exit.
CliResult runCli(const std::vector<std::string>& args,
                 const std::map<std::string, std::string>& env);

}  // namespace myriad::test
