#include "server_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace myriad::test {
namespace {

using Clock = std::chrono::steady_clock;

std::string makeStderrPath() {
  std::string pattern = "/tmp/myriad-server-stderr-XXXXXX";
  int fd = mkstemp(pattern.data());
  if (fd < 0) throw std::runtime_error("mkstemp failed: " + std::string(std::strerror(errno)));
  close(fd);
  return pattern;
}

}  // namespace

std::string ExitStatus::describe() const {
  if (exited) return "exit " + std::to_string(code);
  return "signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
}

ServerProcess::ServerProcess(const std::vector<std::string>& args,
                             std::chrono::milliseconds timeout, bool appendTestArgs) {
  std::vector<std::string> argv = {MYRIAD_SERVER_PATH};
  argv.insert(argv.end(), args.begin(), args.end());
  if (appendTestArgs) {
    for (const char* a : {"--port", "0", "--host", "127.0.0.1", "--validate"}) argv.push_back(a);
  }
  std::vector<char*> argp;
  for (std::string& a : argv) argp.push_back(a.data());
  argp.push_back(nullptr);

  int pipeFds[2];
  if (pipe2(pipeFds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  stderrPath_ = makeStderrPath();

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipeFds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderrPath_.c_str(), O_WRONLY | O_TRUNC,
                                   0);
  // The test runner may have blocked signals; the server must start with a clean mask.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK);
  int rc = posix_spawn(&pid_, argv[0].c_str(), &actions, &attr, argp.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  close(pipeFds[1]);
  stdoutFd_ = pipeFds[0];
  if (rc != 0) {
    close(stdoutFd_);
    throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  }

  // Read stdout until the URL line, end of file (the server exited) or the deadline.
  const auto deadline = Clock::now() + timeout;
  std::string received;
  for (;;) {
    if (size_t at = received.find("http://"); at != std::string::npos) {
      size_t end = received.find('\n', at);
      if (end != std::string::npos) {
        url_ = received.substr(at, end - at);
        size_t colon = url_.rfind(':');
        host_ = url_.substr(7, colon - 7);
        port_ = std::atoi(url_.c_str() + colon + 1);
        start_ = Start::Listening;
        return;
      }
    }
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) break;
    pollfd fd{stdoutFd_, POLLIN, 0};
    int ready = poll(&fd, 1, static_cast<int>(left.count()));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) break;
    char buffer[512];
    ssize_t n = read(stdoutFd_, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      // Stdout closed: the process has ended (or is ending); collect its status.
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (waitForExit(left)) {
        start_ = Start::Exited;
        return;
      }
      break;
    }
    received.append(buffer, size_t(n));
  }
  start_ = Start::TimedOut;
  signal(SIGKILL);
  exitStatus_ = reap(true);
}

ServerProcess::~ServerProcess() {
  if (!exitStatus_ && pid_ > 0) {
    signal(SIGKILL);
    reap(true);
  }
  if (stdoutFd_ >= 0) close(stdoutFd_);
  if (!stderrPath_.empty()) unlink(stderrPath_.c_str());
}

void ServerProcess::signal(int signal) const {
  if (!exitStatus_ && pid_ > 0) kill(pid_, signal);
}

std::optional<ExitStatus> ServerProcess::reap(bool block) {
  if (exitStatus_) return exitStatus_;
  int status = 0;
  pid_t r;
  do {
    r = waitpid(pid_, &status, block ? 0 : WNOHANG);
  } while (r < 0 && errno == EINTR);
  if (r != pid_) return std::nullopt;
  ExitStatus s;
  s.exited = WIFEXITED(status);
  s.code = s.exited ? WEXITSTATUS(status) : 0;
  s.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  exitStatus_ = s;
  return s;
}

std::optional<ExitStatus> ServerProcess::waitForExit(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    if (std::optional<ExitStatus> s = reap(false)) return s;
    if (Clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::optional<ExitStatus> ServerProcess::stop(std::chrono::milliseconds timeout) {
  signal(SIGTERM);
  if (std::optional<ExitStatus> s = waitForExit(timeout)) return s;
  signal(SIGKILL);
  reap(true);
  return std::nullopt;
}

namespace {

// A "VmRSS:  1234 kB" line of /proc/PID/status, in bytes.
uint64_t statusBytes(pid_t pid, std::string_view field) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.starts_with(field)) return std::stoull(line.substr(field.size())) * 1024;
  }
  return 0;
}

}  // namespace

uint64_t ServerProcess::residentBytes() const { return statusBytes(pid_, "VmRSS:"); }
uint64_t ServerProcess::peakResidentBytes() const { return statusBytes(pid_, "VmHWM:"); }

std::string ServerProcess::stderrText() const {
  std::ifstream file(stderrPath_);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

}  // namespace myriad::test
