// GET /v1/sessions/{id}/stream: a multipart/x-mixed-replace response that carries a new frame
// whenever the session changes (or continuously while its lights animate), at most `fps` a second.
// With codec= the same frames go out as video instead (protocol::kVideoStreamContentType): the
// stream joins its session's video channel for that video (SharedFrames: one encoder shared by
// every stream asking for the same target, size, codec, bitrate and fps, freed with the last);
// its first chunk is a key frame; idle re-sends become keep-alive chunks without a picture.
// With container=webm|mp4 the stream frames the same packets in a standard container instead
// (encode::ContainerWriter, its own per stream: the header with its first key frame, time from
// 0), and idle re-sends become bytes every player skips.
//
// At most two frames in flight per stream: the next frame is rendered from the session's newest
// state after the previous part was written, so a slow client sees fewer, newer frames and
// nothing queues; except that while the lights animate and frames take longer than 1 / fps, the
// next frame is submitted as soon as this one is rendered, before it is encoded, so rendering
// overlaps encoding and writing (an edit then shows one frame later; a stream that ends gives
// that frame up unless it already started). While nothing changes the last part is re-sent every
// kIdleResend, which keeps proxies from timing the connection out and tells a client that just connected what the scene looks like.
// With ?interactive=FPS, frames rendered while the session keeps changing are cheaper (smaller,
// their scale chosen from measured frame times; interactive_quality.h) and marked
// X-Myriad-Interactive, and a full-quality still follows once the session settles.
// A stream ends when the client goes away (seen before each frame is rendered, through PeerWatch,
// or when a write fails: a client that takes no byte for kStreamWriteStall fails the write), the
// session closes (deleted or expired), the viewer token it was opened with is revoked or expires,
// or the server shuts down (StreamRegistry::shutdown wakes every waiting stream). Each of these
// wakes a waiting stream at once (a revocation notifies the session's condition variable; a
// token's expiry is one of the wait's deadlines), so it ends within the frame it is rendering.
// An image stream that ends because its session or token did sends a last part first, an
// application/problem+json saying why; a video stream just ends (its chunks have no kind for it).
#pragma once

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <list>
#include <string>
#include <string_view>

#include "protocol/constants.h"
#include "encode/video.h"
#include "service/frame_query.h"
#include "service/peer_watch.h"
#include "service/session.h"
#include "service/session_frames.h"
#include "service/stream_registry.h"

namespace myriad::service {

// The boundary and Content-Type are protocol::kStreamBoundary and protocol::kStreamContentType.
inline constexpr std::chrono::seconds kIdleResend{2};
// A stream's client that takes no byte of a part for this long loses the stream (its write fails;
// connection::setWriteStallLimit), so a reader that stopped reading gives its place back within
// 5 s of its buffers filling. A live reader on a slow link still takes some bytes every few
// seconds; single frames keep connection::kDefaultWriteStall, since a big PNG takes a while.
inline constexpr std::chrono::seconds kStreamWriteStall{3};
// Delivery: a stream knows how much of what it wrote its client has acknowledged (the kernel's
// count of unacknowledged bytes, PeerWatch::unacknowledged). A client whose oldest unacknowledged
// write is older than kStreamLag plus two round trips is behind: its stream makes no frame for
// it until it catches up, so what waits for a slow link is at most about kStreamLag of frames,
// never the kernel's send buffer (megabytes: seconds of lag on a capped link), and no encode
// runs for a client that is not reading. Behind for kStreamRateWindow, its link's rate is
// measured from the acknowledged bytes; a video stream caps its channel's bitrate to it
// (SharedFrames::capVideoBitrate). A client that acknowledges nothing for kStreamWriteStall with
// bytes outstanding (stopped, or reading a byte now and then, which opens no TCP window) loses
// the stream, as a failed write does: its place and its encoder go back.
inline constexpr std::chrono::milliseconds kStreamLag{150};

// The token a stream was opened with. The owner's ends only with its session; a viewer token's
// stream also ends when that token is revoked (DELETE .../tokens, or pushed out by newer ones)
// or expires.
struct StreamCredential {
  std::string viewerHash;      // the viewer token's SHA-256 (ViewerToken::hash); "": the owner's
  int64_t expiresAtUnix = 0;   // the viewer token's expiry when the stream opened
};

// Why a stream (or an event stream) must end, as far as its session and token say.
enum class StreamEnd {
  none,            // it goes on
  quietly,         // replaced, shutdown, or its session reloaded: no part says why
  sessionDeleted,  // the rest end saying why
  sessionExpired,
  viewerRevoked,
  viewerExpired,
};

// Whether a stream of `session` opened with `credential` must end now, given the wall clock in
// Unix seconds: the session closed, or the viewer token was revoked or expired. session.mutex
// held. Image streams, video streams and event streams all end by this one check.
StreamEnd credentialEndNow(const Session& session, const StreamCredential& credential,
                           int64_t nowUnix);

// The chunked content provider of one stream. `slot` is held until the response is destroyed.
httplib::ContentProviderWithoutLength makeStreamProvider(const SessionFrameContext& context,
                                                         StreamRegistry& registry,
                                                         std::unique_ptr<StreamRegistry::Slot> slot,
                                                         SessionPtr session, FrameRequest request,
                                                         PeerWatch peer,
                                                         StreamCredential credential = {});

// GET /v1/sessions/{id}/events: Server-Sent Events of the session's version. On open an
// `event: version` with `data: {"version": N, "role": "owner" | "viewer"}`, then one each time the version changes, a
// `: keep-alive` comment every kEventKeepAlive while nothing does; it ends when the session closes
// or the viewer token it was opened with is revoked or expires (credentialEndNow), with a last
// `event: end` whose data says {"reason": "deleted" | "expired" | "revoked"}, and quietly on
// shutdown or when its client goes away (looked at every kEventPoll). It takes no stream slot but
// holds a worker thread for its life: at most kMaxEventStreamsPerSession per session
// (Session::eventStreams counts them; protocol::limits::kMaxEventStreamsPerSession names it).
inline constexpr std::chrono::seconds kEventKeepAlive{15};
inline constexpr std::chrono::seconds kEventPoll{1};
inline constexpr uint32_t kMaxEventStreamsPerSession = 6;
// And server-wide: with the default 32 workers, 8 frame streams and 4 queued frames, 12 event
// streams leave workers for every other request.
inline constexpr uint32_t kMaxEventStreams = 12;

// The provider of one event stream. The caller counted it in session->eventStreams; the provider
// gives the place back when the stream ends; it ends quietly once `registry` is stopping.
httplib::ContentProviderWithoutLength makeEventStreamProvider(SessionPtr session,
                                                              const StreamRegistry& registry,
                                                              PeerWatch peer,
                                                              StreamCredential credential);

// A video stream's chunk header (protocol::video_chunk gives the layout).
struct VideoChunk {
  uint8_t kind = 0;  // protocol::video_chunk::kKey, kDelta or kKeepAlive
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t sequence = 0;
  uint64_t timestampUs = 0;
  uint64_t version = 0;
  double time = 0.0;
  uint32_t encodeUs = 0;
};

// One chunk's bytes: the header, then the payload (the frame's bitstream; empty for keep-alive).
std::string videoChunk(const VideoChunk& header, std::string_view payload);

// One part's bytes: headers, image, CRLF and the next boundary line (so a reader that splits on
// boundaries has the part at once). The first part of a stream also carries the opening boundary.
// `interactiveScale` (not empty: an interactive frame) becomes its X-Myriad-Interactive header.
std::string multipartPart(std::string_view contentType, std::string_view image, uint64_t sequence,
                          bool first, std::string_view interactiveScale = {});

// The last part of an image stream that ended for `problem` (application/problem+json, no
// X-Myriad-Frame), framed as every other part: a reader that splits on boundaries has it at once,
// and the end of the body follows.
std::string problemPart(const Problem& problem, bool first);

}  // namespace myriad::service
