// The loader child: this executable re-executed with --myriad-loader-child. It narrows what it may
// do (limits below), reads one request from stdin, parses it with the scene loader, writes one
// reply to stdout and exits. Everything that can go wrong with a hostile file happens here.
#include <linux/close_range.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <fcntl.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <string>

#include "loader/archive.h"
#include "loader/child_protocol.h"
#include "loader/hdr_decode.h"
#include "loader/loader.h"
#include "loader/sandbox.h"
#include "loader/scene_wire.h"
#include "scene/model_loader.h"

namespace myriad::loader {

namespace {

using namespace child;

// Files the child may hold open at once besides stdin/stdout/stderr: a glTF and its buffers are
// read one after another, so a handful is plenty, and a file that makes Assimp leak descriptors
// fails instead of exhausting anything.
constexpr rlim_t kMaxOpenFiles = 16;

bool readAll(int fd, void* buffer, size_t size) {
  auto* at = static_cast<char*>(buffer);
  while (size > 0) {
    const ssize_t n = ::read(fd, at, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    at += n;
    size -= size_t(n);
  }
  return true;
}

bool writeAll(int fd, const void* buffer, size_t size) {
  auto* at = static_cast<const char*>(buffer);
  while (size > 0) {
    const ssize_t n = ::write(fd, at, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    at += n;
    size -= size_t(n);
  }
  return true;
}

void setLimit(int resource, rlim_t soft, rlim_t hard) {
  const rlimit limit{soft, hard};
  ::setrlimit(resource, &limit);  // may only lower limits; failing leaves the stricter one
}

// Descriptors the server opened without O_CLOEXEC (a library's socket, say) would otherwise live
// on in the child for as long as it runs.
void closeInheritedDescriptors() {
  if (::syscall(SYS_close_range, 3u, ~0u, 0u) == 0) return;
  for (int fd = 3; fd < 1024; ++fd) ::close(fd);
}

// Called by operator new when an allocation fails, which under RLIMIT_AS means the model wants
// more memory than it is allowed. Exiting here, before Assimp can catch std::bad_alloc and report
// it as a parse error, lets the parent name the reason exactly.
void outOfMemory() { ::_exit(kExitOutOfMemory); }

int rejected(scene::ModelLoadError::Kind kind, std::string sentence);

// What opening `path` for reading does now: "opened" or the error.
std::string probe(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::strerror(errno);
  ::close(fd);
  return "opened";
}

[[noreturn]] void commit(InjectedFault fault, Mode mode, const std::string& name) {
  switch (fault) {
    case InjectedFault::crash:
      ::raise(SIGSEGV);
      break;
    case InjectedFault::hang:
      for (;;) ::pause();
    case InjectedFault::spin: {
      volatile uint64_t counter = 0;
      for (;;) counter = counter + 1;
    }
    case InjectedFault::allocate: {
      static char* volatile newest = nullptr;  // keeps the allocations observable
      for (;;) {
        char* block = new char[16 << 20];
        std::memset(block, 1, 16 << 20);  // touched, so it is really used
        *reinterpret_cast<char**>(block) = newest;
        newest = block;
      }
    }
    case InjectedFault::probeFiles:
      ::_exit(rejected(scene::ModelLoadError::Kind::parse,
                       "own file: " + (mode == Mode::file ? probe(name) : std::string("none")) +
                           "; /etc/passwd: " + probe("/etc/passwd")));
    case InjectedFault::none:
      break;
  }
  ::_exit(kExitBadRequest);
}

int reply(uint8_t status, const std::string& body) {
  std::string out(kReplyMagic, 4);
  out += char(status);
  out += body;
  return writeAll(STDOUT_FILENO, out.data(), out.size()) ? 0 : kExitWriteFailed;
}

int rejected(scene::ModelLoadError::Kind kind, std::string sentence) {
  if (sentence.size() > kMaxSentenceBytes) sentence.resize(kMaxSentenceBytes);
  std::string body(1, char(kind));
  const uint32_t length = uint32_t(sentence.size());
  body.append(reinterpret_cast<const char*>(&length), 4);
  body += sentence;
  return reply(kReplyRejected, body);
}

int serve() {
  closeInheritedDescriptors();
  setLimit(RLIMIT_CORE, 0, 0);   // a crash must not write a core of a 2 GiB address space
  setLimit(RLIMIT_FSIZE, 0, 0);  // it reads files, never writes one
  setLimit(RLIMIT_NOFILE, kMaxOpenFiles, kMaxOpenFiles);
  setLimit(RLIMIT_NPROC, 0, 0);  // and starts no processes (counts the user's, so only fork fails)

  RequestHeader header;
  if (!readAll(STDIN_FILENO, &header, sizeof header) ||
      std::memcmp(header.magic, kRequestMagic, 4) != 0 || header.version != kProtocolVersion ||
      header.nameBytes > kMaxNameBytes || header.entryBytes > kMaxNameBytes) {
    return kExitBadRequest;
  }
  const rlim_t cpu = header.cpuSeconds;
  // SIGXCPU at the soft limit (the parent reports "timeout"), SIGKILL a second later if ignored.
  setLimit(RLIMIT_CPU, cpu, cpu + 1);
#if !defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer reserves terabytes of address space for its shadow; there the memory limit
  // is left to the wall clock.
  setLimit(RLIMIT_AS, header.memoryBytes, header.memoryBytes);
#endif
  std::set_new_handler(outOfMemory);

  std::string name(header.nameBytes, '\0');
  std::string entry(header.entryBytes, '\0');
  uint64_t dataBytes = 0;
  if (!readAll(STDIN_FILENO, name.data(), name.size()) ||
      !readAll(STDIN_FILENO, entry.data(), entry.size()) ||
      !readAll(STDIN_FILENO, &dataBytes, sizeof dataBytes)) {
    return kExitBadRequest;
  }
  // From here on, the file system holds only the model's own directory (nothing, for an upload),
  // whatever Assimp or a bug in it tries; without Landlock, ConfinedIOSystem alone keeps Assimp's
  // own file access to that directory.
  std::error_code error;
  const std::filesystem::path readable =
      header.mode == Mode::file || header.mode == Mode::environmentFile
          ? std::filesystem::weakly_canonical(name, error).parent_path()
                                : std::filesystem::path();
  enterSandbox(readable);

  const auto fault = InjectedFault(header.fault);
  if (fault != InjectedFault::none) commit(fault, header.mode, name);

  try {
    std::string data(dataBytes, '\0');
    if (!readAll(STDIN_FILENO, data.data(), data.size())) return kExitBadRequest;
    const ArchiveLimits archiveLimits{header.maxArchiveEntries, header.maxArchiveBytes,
                                      header.maxCompressionRatio};
    scene::Scene scene;
    switch (header.mode) {
      case Mode::file: scene = scene::loadModel(name); break;
      case Mode::bytes: scene = scene::loadModelFromMemory(data, name); break;
      case Mode::archive:
      case Mode::files: {
        const scene::MemoryFiles files = header.mode == Mode::archive
                                             ? readZipArchive(data, name, archiveLimits)
                                             : decodeFileSet(data, name, archiveLimits);
        data = std::string();  // the archive's bytes are no longer needed
        scene = scene::loadModelFromFiles(files, scene::modelEntryOf(files, entry, name));
        break;
      }
      case Mode::environmentBytes:
      case Mode::environmentFile: {
        if (header.mode == Mode::environmentFile) {
          std::ifstream in(name, std::ios::binary);
          if (!in) {
            return rejected(scene::ModelLoadError::Kind::parse,
                            "Cannot open the environment image: " + std::string(std::strerror(errno)));
          }
          data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        }
        const std::string shown = std::filesystem::path(name).filename().string();
        const scene::EnvironmentImage image = decodeHdr(data, shown, HdrLimits{});
        return reply(kReplyEnvironment,
                     std::string(reinterpret_cast<const char*>(image.rgb.data()),
                                 image.rgb.size() * sizeof(float)));
      }
      default: return kExitBadRequest;
    }
    return reply(kReplyScene, encodeScene(scene));
  } catch (const scene::ModelLoadError& e) {
    return rejected(e.kind(), e.what());
  } catch (const std::bad_alloc&) {
    return kExitOutOfMemory;
  } catch (const std::exception& e) {
    return rejected(scene::ModelLoadError::Kind::parse,
                    "Cannot load model '" + std::string(name) + "': " + e.what());
  }
}

}  // namespace

bool runChildIfRequested(int argc, char** argv) {
  if (argc < 2 || argv[1] != kChildFlag) return false;
  // _exit: no static destructors or atexit handlers of a process that may be in a bad state.
  ::_exit(serve());
}

}  // namespace myriad::loader
