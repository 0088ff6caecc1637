// What the parent and the loader child say to each other over the child's stdin and stdout. Both
// ends are this executable, so the layout is shared by including this file; the parent still
// checks every byte it reads back (decodeScene).
//
// Request (stdin):  "MYLQ" u32 version u8 mode u8 fault u16 0 u32 cpuSeconds u64 memoryBytes
//                   u32 maxArchiveEntries u32 maxCompressionRatio u64 maxArchiveBytes
//                   u32 nameBytes u32 entryBytes, name (a file name for messages and the format
//                   hint, or the path to open), entry (archive and files: the model's member path,
//                   empty = find the one model file), u64 dataBytes, data (the upload: the file,
//                   the zip archive, or the file set of archive.h; none for a file)
// Reply (stdout):   "MYLR" u8 status, then for kReplyScene the scene (scene_wire.h), for
//                   kReplyRejected u8 ModelLoadError::Kind, u32 sentenceBytes, sentence, for
//                   kReplyEnvironment 256 x 128 x 3 f32 (scene/environment_map.h).
#pragma once

#include <cstdint>

namespace myriad::loader::child {

inline constexpr char kRequestMagic[4] = {'M', 'Y', 'L', 'Q'};
inline constexpr char kReplyMagic[4] = {'M', 'Y', 'L', 'R'};
inline constexpr uint32_t kProtocolVersion = 2;

enum class Mode : uint8_t {
  bytes = 0,    // one uploaded file
  file = 1,     // a library file, opened by path
  archive = 2,  // a zip archive (application/zip upload)
  files = 3,    // several uploaded files (multipart/form-data), as archive.h's file set
  environmentBytes = 4,  // an uploaded Radiance .hdr (environment light)
  environmentFile = 5,   // a library .hdr, opened by path
};

#pragma pack(push, 1)
struct RequestHeader {
  char magic[4];
  uint32_t version;
  Mode mode;
  uint8_t fault;  // InjectedFault
  uint16_t reserved;
  uint32_t cpuSeconds;
  uint64_t memoryBytes;
  uint32_t maxArchiveEntries;
  uint32_t maxCompressionRatio;
  uint64_t maxArchiveBytes;
  uint32_t nameBytes;
  uint32_t entryBytes;
};
#pragma pack(pop)

inline constexpr uint32_t kMaxNameBytes = 4096;

inline constexpr uint8_t kReplyScene = 0;
inline constexpr uint8_t kReplyRejected = 1;
inline constexpr uint8_t kReplyEnvironment = 2;  // scene::EnvironmentImage's floats, raw
inline constexpr uint32_t kMaxSentenceBytes = 2048;

// Exit statuses of the child beyond 0, so the parent can tell why it ended without a reply.
inline constexpr int kExitOutOfMemory = 86;  // an allocation failed under RLIMIT_AS
inline constexpr int kExitBadRequest = 87;   // the parent sent something malformed (a bug)
inline constexpr int kExitWriteFailed = 88;  // the parent stopped reading

}  // namespace myriad::loader::child
