// The parent side: start the child, feed it the request and collect its reply concurrently under
// a wall-clock deadline, reap it, and turn how it ended into a scene or a ModelRejected.
#include "loader/loader.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "loader/child_protocol.h"
#include "loader/hdr_decode.h"
#include "loader/sandbox.h"
#include "loader/scene_wire.h"
#include "scene/model_loader.h"

extern char** environ;

namespace myriad::loader {

namespace {

using namespace child;
using Clock = std::chrono::steady_clock;

// The longest file name kept for messages; the rest is cut.
constexpr size_t kMaxShownName = 120;

// A file descriptor closed on scope exit.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { reset(); }
  int get() const { return fd_; }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

struct Pipe {
  Fd read, write;
};

[[noreturn]] void internal(const std::string& what) {
  throw ModelRejected("internal", "The model loader could not run: " + what + ".");
}

Pipe makePipe() {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) internal(std::string("pipe: ") + std::strerror(errno));
  return Pipe{Fd(fds[0]), Fd(fds[1])};
}

// The name as it appears in messages: the last path component, printable, not too long.
std::string shownName(std::string_view filename) {
  const size_t slash = filename.find_last_of("/\\");
  if (slash != std::string_view::npos) filename.remove_prefix(slash + 1);
  std::string name;
  for (const char c : filename.substr(0, kMaxShownName)) {
    name += static_cast<unsigned char>(c) < 0x20 || c == 0x7F || c == '\'' ? '_' : c;
  }
  return name.empty() ? "upload" : name;
}

std::string signalName(int signal) {
  switch (signal) {
    case SIGSEGV: return "SIGSEGV";
    case SIGABRT: return "SIGABRT";
    case SIGBUS: return "SIGBUS";
    case SIGFPE: return "SIGFPE";
    case SIGILL: return "SIGILL";
    case SIGKILL: return "SIGKILL";
    case SIGXCPU: return "SIGXCPU";
    case SIGXFSZ: return "SIGXFSZ";
    case SIGSYS: return "SIGSYS";
    case SIGPIPE: return "SIGPIPE";
    default: return "signal " + std::to_string(signal);
  }
}

std::string mebibytes(uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// SIGPIPE is thread-directed when a write to a pipe fails; blocked here it stays pending on this
// thread and is swallowed before the mask is restored, whatever the server's own disposition.
class SigpipeGuard {
 public:
  SigpipeGuard() {
    sigemptyset(&pipe_);
    sigaddset(&pipe_, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_, &old_);
  }
  ~SigpipeGuard() {
    const timespec zero{0, 0};
    while (sigtimedwait(&pipe_, nullptr, &zero) > 0) {
    }
    pthread_sigmask(SIG_SETMASK, &old_, nullptr);
  }

 private:
  sigset_t pipe_, old_;
};

// What the child did, before it is interpreted.
struct ChildRun {
  int status = 0;         // from wait4
  bool killedByUs = false;  // the wall-clock deadline passed
  bool outputTooLarge = false;
  double cpuSeconds = 0.0;
  std::string output;
};

// A started child, killed and reaped on every way out of scope (an exception included), so no
// path leaves a zombie or a runaway process behind.
class ChildProcess {
 public:
  explicit ChildProcess(pid_t pid) : pid_(pid) {}
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ~ChildProcess() {
    if (!reaped_) reap(true);
  }
  pid_t pid() const { return pid_; }
  bool reaped() const { return reaped_; }

  // Non-blocking: whether it has exited (and is now reaped).
  bool poll() {
    if (!reaped_ && ::wait4(pid_, &status_, WNOHANG, &usage_) == pid_) reaped_ = true;
    return reaped_;
  }
  // Blocking; with `kill`, SIGKILL first.
  void reap(bool kill) {
    if (reaped_) return;
    if (kill) ::kill(pid_, SIGKILL);
    while (::wait4(pid_, &status_, 0, &usage_) < 0 && errno == EINTR) {
    }
    reaped_ = true;
  }
  int status() const { return status_; }
  double cpuSeconds() const {
    return double(usage_.ru_utime.tv_sec + usage_.ru_stime.tv_sec) +
           double(usage_.ru_utime.tv_usec + usage_.ru_stime.tv_usec) * 1e-6;
  }

 private:
  pid_t pid_;
  bool reaped_ = false;
  int status_ = 0;
  rusage usage_{};
};

pid_t spawnChild(int stdinFd, int stdoutFd) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, stdinFd, STDIN_FILENO);
  posix_spawn_file_actions_adddup2(&actions, stdoutFd, STDOUT_FILENO);
  // Assimp and the C++ runtime may print on a crash; the server's log is not the place.
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);

  // The server blocks SIGINT/SIGTERM in every thread and may ignore SIGPIPE; the child starts
  // with the defaults, so SIGXCPU and a dead stdout end it.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int signal : {SIGPIPE, SIGINT, SIGTERM, SIGHUP, SIGCHLD, SIGXCPU, SIGXFSZ, SIGSEGV, SIGBUS,
                     SIGABRT, SIGFPE, SIGILL, SIGUSR1, SIGUSR2, SIGALRM}) {
    sigaddset(&defaults, signal);
  }
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);

  char program[] = "/proc/self/exe";
  std::string flag(kChildFlag);
  char name[] = "myriad-loader";
  char* argv[] = {name, flag.data(), nullptr};
  pid_t pid = -1;
  const int error = posix_spawn(&pid, program, &actions, &attributes, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (error != 0) internal(std::string("cannot start the child: ") + std::strerror(error));
  return pid;
}

// Feeds `request` (chunks written in order) to a fresh child and reads its whole stdout, within
// the wall-clock limit. Always reaps the child before returning or throwing.
ChildRun runChild(const std::vector<std::string_view>& request, const LoadLimits& limits) {
  Pipe input = makePipe();
  Pipe output = makePipe();
  ::fcntl(input.write.get(), F_SETFL, O_NONBLOCK);
  ::fcntl(output.read.get(), F_SETFL, O_NONBLOCK);

  const SigpipeGuard sigpipe;
  ChildProcess child(spawnChild(input.read.get(), output.write.get()));
  // The child has its own copies now; ours would keep the pipes open past its exit.
  input.read.reset();
  output.write.reset();
  // Tells when the child exits even if it closed stdout early; without it (old kernels) the loop
  // below wakes every few milliseconds to ask.
  Fd exited(int(::syscall(SYS_pidfd_open, child.pid(), 0)));

  ChildRun run;
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(limits.wallSeconds);
  // Reply magic and status, then at most the scene the caller accepts.
  const uint64_t maxOutput = limits.maxOutputBytes + 5;
  size_t chunk = 0, offset = 0;
  bool childExited = false;
  char buffer[1 << 16];

  while (output.read.get() >= 0 || !childExited) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      run.killedByUs = true;
      break;
    }
    pollfd fds[3];
    nfds_t count = 0;
    int inIndex = -1, outIndex = -1, exitIndex = -1;
    if (input.write.get() >= 0) {
      inIndex = int(count);
      fds[count++] = {input.write.get(), POLLOUT, 0};
    }
    if (output.read.get() >= 0) {
      outIndex = int(count);
      fds[count++] = {output.read.get(), POLLIN, 0};
    }
    if (!childExited && exited.get() >= 0) {
      exitIndex = int(count);
      fds[count++] = {exited.get(), POLLIN, 0};
    }
    const bool askEachTime = !childExited && exited.get() < 0;
    const int timeout = int(std::min<long long>(left, askEachTime ? 10 : 60'000));
    const int ready = ::poll(fds, count, timeout);
    if (ready < 0 && errno != EINTR) internal(std::string("poll: ") + std::strerror(errno));
    if (askEachTime && child.poll()) childExited = true;
    if (ready <= 0) continue;

    if (inIndex >= 0 && fds[inIndex].revents != 0) {
      // POLLERR: the child closed its stdin (exited, or stopped reading); its reply says why.
      bool done = (fds[inIndex].revents & POLLOUT) == 0;
      while (!done && chunk < request.size()) {
        const std::string_view piece = request[chunk].substr(offset);
        const ssize_t n = ::write(input.write.get(), piece.data(), piece.size());
        if (n < 0) {
          done = errno != EAGAIN && errno != EINTR;
          if (!done) break;
        } else if (size_t(n) == piece.size()) {
          ++chunk;
          offset = 0;
        } else {
          offset += size_t(n);
          break;
        }
      }
      if (done || chunk == request.size()) input.write.reset();
    }
    if (outIndex >= 0 && fds[outIndex].revents != 0) {
      const ssize_t n = ::read(output.read.get(), buffer, sizeof buffer);
      if (n > 0) {
        run.output.append(buffer, size_t(n));
        if (run.output.size() > maxOutput) {
          run.outputTooLarge = true;
          break;
        }
      } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
        output.read.reset();
      }
    }
    if (exitIndex >= 0 && fds[exitIndex].revents != 0) childExited = true;
  }

  child.reap(!childExited);
  run.status = child.status();
  run.cpuSeconds = child.cpuSeconds();
  return run;
}

// Reads the child's reply, or explains why there is none: the body of a reply with status
// `expected`. `noun` is what the messages call the file ("model", "environment image").
std::string_view replyBody(const ChildRun& run, const std::string& name, const LoadLimits& limits,
                           uint8_t expected, const std::string& noun) {
  const std::string model = "'" + name + "'";
  if (run.outputTooLarge) {
    throw ModelRejected("too-large", "The " + noun + " " + model + " is too large: its meshes exceed " +
                                         mebibytes(limits.maxOutputBytes) + ".");
  }
  const std::string timeout = "Loading the " + noun + " " + model + " took longer than " +
                              std::to_string(limits.wallSeconds) + " s and was stopped.";
  if (run.killedByUs) throw ModelRejected("timeout", timeout);
  const std::string memory = "Loading the " + noun + " " + model + " needed more than " +
                             mebibytes(limits.memoryBytes) + " of memory and was stopped.";
  if (WIFSIGNALED(run.status)) {
    const int signal = WTERMSIG(run.status);
    if (signal == SIGXCPU || (signal == SIGKILL && run.cpuSeconds >= limits.cpuSeconds)) {
      throw ModelRejected("timeout", "Loading the " + noun + " " + model + " used more than " +
                                         std::to_string(limits.cpuSeconds) +
                                         " s of CPU time and was stopped.");
    }
    // We did not send it and the CPU limit was not reached: the kernel's out-of-memory killer.
    if (signal == SIGKILL) throw ModelRejected("memory", memory);
    throw ModelRejected("crash", "The model loader crashed (" + signalName(signal) +
                                     ") while reading " + model + "; the file is malformed.");
  }
  const int code = WIFEXITED(run.status) ? WEXITSTATUS(run.status) : -1;
  if (code == kExitOutOfMemory) throw ModelRejected("memory", memory);
  if (code != 0) {
    throw ModelRejected("crash", "The model loader failed on " + model + " (exit status " +
                                     std::to_string(code) + ").");
  }

  const std::string_view reply = run.output;
  const std::string garbled = "The model loader returned inconsistent data for " + model;
  if (reply.size() < 5 || std::memcmp(reply.data(), kReplyMagic, 4) != 0) {
    throw ModelRejected("crash", garbled + " (no reply).");
  }
  const std::string_view body = reply.substr(5);
  if (uint8_t(reply[4]) == kReplyRejected) {
    uint32_t length = 0;
    if (body.size() < 5 || (std::memcpy(&length, body.data() + 1, 4), length) != body.size() - 5 ||
        length > kMaxSentenceBytes) {
      throw ModelRejected("crash", garbled + " (a malformed refusal).");
    }
    using Kind = scene::ModelLoadError::Kind;
    const auto kind = Kind(uint8_t(body[0]));
    const std::string reason = kind == Kind::empty         ? "empty"
                               : kind == Kind::unsupported ? "unsupported"
                               : kind == Kind::tooLarge    ? "too-large"
                                                           : "parse";
    // Assimp's messages may quote the file (any bytes, line breaks included); the sentence goes
    // into JSON and logs.
    throw ModelRejected(reason, cleanText(body.substr(5)));
  }
  if (uint8_t(reply[4]) != expected) throw ModelRejected("crash", garbled + " (bad status).");
  return body;
}

scene::Scene interpret(const ChildRun& run, const std::string& name, const LoadLimits& limits) {
  const std::string model = "'" + name + "'";
  const std::string garbled = "The model loader returned inconsistent data for " + model;
  const std::string_view body = replyBody(run, name, limits, kReplyScene, "model");
  scene::Scene scene;
  try {
    scene = decodeScene(body);
  } catch (const SceneWireError& e) {
    throw ModelRejected("crash", garbled + " (" + e.what() + ").");
  }
  if (scene.instances.empty()) {
    throw ModelRejected("empty", "Cannot load model " + model + ": it contains no triangle meshes.");
  }
  return scene;
}

// Turns to run a child, shared by every thread of the process.
class ChildSlots {
 public:
  explicit ChildSlots(unsigned capacity) : capacity_(capacity) {}

  bool acquire(Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    if (!freed_.wait_until(lock, deadline, [&] { return used_ < capacity_; })) return false;
    ++used_;
    return true;
  }
  void release() {
    {
      const std::lock_guard lock(mutex_);
      --used_;
    }
    freed_.notify_one();
  }
  unsigned capacity() const { return capacity_; }

 private:
  const unsigned capacity_;
  std::mutex mutex_;
  std::condition_variable freed_;
  unsigned used_ = 0;
};

ChildSlots& childSlots() {
  static ChildSlots slots(std::clamp(std::thread::hardware_concurrency(), 2u, 8u));
  return slots;
}

ChildRun runRequest(Mode mode, const std::string& nameOrPath, std::string_view data,
                    const LoadLimits& limits, std::string_view entry = {}) {
  RequestHeader header{};
  std::memcpy(header.magic, kRequestMagic, 4);
  header.version = kProtocolVersion;
  header.mode = mode;
  header.fault = uint8_t(limits.fault);
  header.cpuSeconds = limits.cpuSeconds;
  header.memoryBytes = limits.memoryBytes;
  header.maxArchiveEntries = limits.archive.maxEntries;
  header.maxCompressionRatio = limits.archive.maxCompressionRatio;
  header.maxArchiveBytes = limits.archive.maxBytes;
  header.nameBytes = uint32_t(nameOrPath.size());
  header.entryBytes = uint32_t(entry.size());
  const uint64_t dataBytes = data.size();

  const std::vector<std::string_view> request = {
      {reinterpret_cast<const char*>(&header), sizeof header},
      nameOrPath,
      entry,
      {reinterpret_cast<const char*>(&dataBytes), sizeof dataBytes},
      data};

  ChildSlots& slots = childSlots();
  if (!slots.acquire(Clock::now() + std::chrono::seconds(limits.wallSeconds))) {
    throw ModelRejected("busy", "The model loader is busy with " +
                                    std::to_string(slots.capacity()) +
                                    " other models; try again shortly.");
  }
  ChildRun run;
  try {
    run = runChild(request, limits);
  } catch (...) {
    slots.release();
    throw;
  }
  slots.release();  // before decoding: the slot bounds children, not parents
  return run;
}

scene::Scene load(Mode mode, const std::string& nameOrPath, const std::string& shown,
                  std::string_view data, const LoadLimits& limits, std::string_view entry = {}) {
  return interpret(runRequest(mode, nameOrPath, data, limits, entry), shown, limits);
}

// The child's environment reply: exactly the image's floats, each finite and in range.
scene::EnvironmentImage environmentFrom(const ChildRun& run, const std::string& shown,
                                        const LoadLimits& limits) {
  const std::string_view body =
      replyBody(run, shown, limits, kReplyEnvironment, "environment image");
  scene::EnvironmentImage image;
  image.rgb.resize(size_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3);
  const std::string garbled = "The model loader returned inconsistent data for '" + shown + "'";
  if (body.size() != image.rgb.size() * sizeof(float)) {
    throw ModelRejected("crash", garbled + " (the image has the wrong size).");
  }
  std::memcpy(image.rgb.data(), body.data(), body.size());
  for (const float v : image.rgb) {
    if (!(v >= 0.0f && v <= kMaxEnvironmentRadiance)) {
      throw ModelRejected("crash", garbled + " (a radiance out of range).");
    }
  }
  return image;
}

}  // namespace

// A binary that links the loader but forgets runChildIfRequested() in main() (a test runner, a
// tool) would otherwise run its whole self as the child: with doctest, every test, in a loop. So
// the child is also recognised here, before main(); glibc passes the arguments to constructors.
__attribute__((constructor)) static void runChildBeforeMain(int argc, char** argv, char**) {
  runChildIfRequested(argc, argv);
}

unsigned maxConcurrentLoads() { return childSlots().capacity(); }

bool childrenSandboxed() { return landlockAbi() > 0; }

scene::Scene loadModelBytes(std::string_view bytes, std::string_view filename,
                            const LoadLimits& limits) {
  const std::string shown = shownName(filename);
  const std::string extension = std::filesystem::path(shown).extension().string();
  // Refused here, without a process, since the answer does not depend on the bytes.
  if (extension.empty() || !scene::isSupportedModelExtension(extension)) {
    throw ModelRejected("unsupported",
                        "Cannot load model '" + shown + "': " +
                            (extension.empty() ? std::string("the file name has no extension")
                                               : "'" + extension + "' is not a model format") +
                            " this server reads.");
  }
  if (bytes.empty()) throw ModelRejected("empty", "Cannot load model '" + shown + "': the file is empty.");
  return load(Mode::bytes, shown, shown, bytes, limits);
}

scene::Scene loadModelArchive(std::string_view zipBytes, std::string_view filename,
                              std::string_view entry, const LoadLimits& limits) {
  const std::string shown = shownName(filename);
  if (entry.size() > kMaxNameBytes) {
    throw ModelRejected("unsupported", "Cannot load model '" + shown + "': the entry is too long.");
  }
  if (zipBytes.empty()) throw ModelRejected("empty", "Cannot load model '" + shown + "': the archive is empty.");
  return load(Mode::archive, shown, shown, zipBytes, limits, entry);
}

scene::Scene loadModelFiles(const scene::MemoryFiles& files, std::string_view entry,
                            const LoadLimits& limits) {
  const std::string shown =
      shownName(entry.empty() ? std::string_view("upload") : std::string_view(entry));
  if (entry.size() > kMaxNameBytes) {
    throw ModelRejected("unsupported", "Cannot load model '" + shown + "': the entry is too long.");
  }
  if (files.empty()) throw ModelRejected("empty", "Cannot load model '" + shown + "': no files were sent.");
  return load(Mode::files, shown, shown, encodeFileSet(files), limits, entry);
}

bool isEnvironmentFileName(std::string_view filename) {
  const std::string extension = std::filesystem::path(shownName(filename)).extension().string();
  return extension.size() == 4 && (extension[1] | 0x20) == 'h' && (extension[2] | 0x20) == 'd' &&
         (extension[3] | 0x20) == 'r';
}

scene::EnvironmentImage loadEnvironmentBytes(std::string_view bytes, std::string_view filename,
                                             const LoadLimits& limits) {
  const std::string shown = shownName(filename.empty() ? std::string_view("upload.hdr") : filename);
  if (bytes.empty()) {
    throw ModelRejected("empty", "The environment image '" + shown + "' is empty.");
  }
  return environmentFrom(runRequest(Mode::environmentBytes, shown, bytes, limits), shown, limits);
}

scene::EnvironmentImage loadEnvironmentFile(const std::filesystem::path& path,
                                            const LoadLimits& limits) {
  const std::string shown = shownName(path.filename().string());
  std::error_code error;
  std::filesystem::path absolute = std::filesystem::absolute(path, error);
  if (error || absolute.native().size() > kMaxNameBytes) {
    throw ModelRejected("unsupported", "Cannot load the environment image '" + shown +
                                           "': its path is too long.");
  }
  return environmentFrom(runRequest(Mode::environmentFile, absolute.string(), {}, limits), shown,
                         limits);
}

scene::Scene loadModelFile(const std::filesystem::path& path, const LoadLimits& limits) {
  const std::string shown = shownName(path.filename().string());
  std::error_code error;
  std::filesystem::path absolute = std::filesystem::absolute(path, error);
  if (error || absolute.native().size() > kMaxNameBytes) absolute = path;
  if (absolute.native().size() > kMaxNameBytes) {
    throw ModelRejected("unsupported", "Cannot load model '" + shown + "': its path is too long.");
  }
  return load(Mode::file, absolute.string(), shown, {}, limits);
}

}  // namespace myriad::loader
