// A myriad-server child process for the server tests: started on a free loopback port with
// validation on, its URL read from stdout, its stderr kept in a file, stopped by SIGTERM.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace myriad::test {

// How a child process ended.
struct ExitStatus {
  bool exited = false;  // by exit(); else killed by `signal`
  int code = 0;
  int signal = 0;

  bool cleanExit() const { return exited && code == 0; }
  std::string describe() const;  // "exit 0", "signal 11 (Segmentation fault)"
};

class ServerProcess {
 public:
  enum class Start { Listening, Exited, TimedOut };

  // Spawns MYRIAD_SERVER_PATH with `args` followed by --port 0 --host 127.0.0.1 --validate (unless
  // appendTestArgs is false), then waits up to `timeout` for the "listening on http://..." line.
  // Kills a server that times out.
  explicit ServerProcess(const std::vector<std::string>& args,
                         std::chrono::milliseconds timeout = std::chrono::seconds(120),
                         bool appendTestArgs = true);
  ~ServerProcess();  // SIGKILL if still running
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  Start start() const { return start_; }
  const std::string& url() const { return url_; }  // "http://127.0.0.1:PORT"
  const std::string& host() const { return host_; }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }

  // Sends SIGTERM (if still running) and waits up to `timeout` for the exit; SIGKILLs after that
  // and returns nullopt.
  std::optional<ExitStatus> stop(std::chrono::milliseconds timeout = std::chrono::seconds(60));

  // Waits for the process to exit by itself; nullopt on timeout (it keeps running).
  std::optional<ExitStatus> waitForExit(std::chrono::milliseconds timeout);

  // Sends `signal` without waiting.
  void signal(int signal) const;

  // Everything the server wrote to stderr so far.
  std::string stderrText() const;

  // The server's resident memory now, and the most it has had (VmRSS, VmHWM), in bytes; 0 once
  // it has exited.
  uint64_t residentBytes() const;
  uint64_t peakResidentBytes() const;

 private:
  std::optional<ExitStatus> reap(bool block);

  pid_t pid_ = -1;
  int stdoutFd_ = -1;
  std::string stderrPath_;
  Start start_ = Start::TimedOut;
  std::string url_;
  std::string host_;
  int port_ = 0;
  std::optional<ExitStatus> exitStatus_;
};

}  // namespace myriad::test
