#include "encode/h264.h"

#include <wels/codec_api.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

namespace myriad::encode {
namespace {

// H.264 Table A-1: level_idc, MaxMBPS (macroblocks a second), MaxFS (macroblocks a frame),
// MaxBR (kbit/s of the VCL, Baseline).
struct LevelLimit {
  uint8_t level;
  uint32_t maxMbps;
  uint32_t maxFs;
  uint32_t maxKbps;
};
constexpr std::array<LevelLimit, 15> kLevels = {{{10, 1485, 99, 64},
                                                 {11, 3000, 396, 192},
                                                 {12, 6000, 396, 384},
                                                 {13, 11880, 396, 768},
                                                 {20, 11880, 396, 2000},
                                                 {21, 19800, 792, 4000},
                                                 {22, 20250, 1620, 4000},
                                                 {30, 40500, 1620, 10000},
                                                 {31, 108000, 3600, 14000},
                                                 {32, 216000, 5120, 20000},
                                                 {40, 245760, 8192, 20000},
                                                 {41, 245760, 8192, 50000},
                                                 {42, 522240, 8704, 50000},
                                                 {50, 589824, 22080, 135000},
                                                 {51, 983040, 36864, 240000}}};
constexpr LevelLimit kLevel52{52, 2073600, 36864, 240000};

std::string codecMessage(const char* what, int code) {
  return std::string(what) + " (OpenH264 error " + std::to_string(code) + ")";
}

}  // namespace

uint8_t h264Level(uint32_t width, uint32_t height, uint32_t fps, uint32_t kbps) {
  const uint64_t mbs = uint64_t((width + 15) / 16) * ((height + 15) / 16);
  if (mbs > kLevel52.maxFs) return 0;
  for (const LevelLimit& limit : kLevels) {
    if (mbs <= limit.maxFs && mbs * fps <= limit.maxMbps && kbps <= limit.maxKbps) {
      return limit.level;
    }
  }
  return kLevel52.level;
}

// ---- Encoder.

struct H264Encoder::Impl {
  ISVCEncoder* encoder = nullptr;
  bool initialized = false;
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> planes;  // I420: Y, then U, then V, tightly packed
  uint64_t frames = 0;

  ~Impl() {
    if (encoder == nullptr) return;
    if (initialized) encoder->Uninitialize();
    WelsDestroySVCEncoder(encoder);
  }
};

H264Encoder::H264Encoder(const VideoSettings& settings) : impl_(std::make_unique<Impl>()) {
  if (settings.width % 2 != 0 || settings.height % 2 != 0) {
    throw std::invalid_argument("h264 frames must have an even width and height, not " +
                                std::to_string(settings.width) + "x" +
                                std::to_string(settings.height));
  }
  const uint8_t level =
      h264Level(settings.width, settings.height, settings.fps, settings.bitrateKbps);
  if (level == 0) {
    throw std::invalid_argument("h264 frames must be at most 36,864 macroblocks (4096x2304), not " +
                                std::to_string(settings.width) + "x" +
                                std::to_string(settings.height));
  }
  if (WelsCreateSVCEncoder(&impl_->encoder) != 0 || impl_->encoder == nullptr) {
    throw VideoError("OpenH264 could not make an encoder");
  }
  ISVCEncoder* encoder = impl_->encoder;
  int trace = WELS_LOG_QUIET;  // its warnings go to stderr otherwise; failures are returned
  encoder->SetOption(ENCODER_OPTION_TRACE_LEVEL, &trace);

  SEncParamExt param{};
  encoder->GetDefaultParams(&param);
  param.iUsageType = CAMERA_VIDEO_REAL_TIME;
  param.iPicWidth = int(settings.width);
  param.iPicHeight = int(settings.height);
  param.iTargetBitrate = int(settings.bitrateKbps * 1000);
  param.iMaxBitrate = UNSPECIFIED_BIT_RATE;
  param.iRCMode = RC_BITRATE_MODE;
  param.fMaxFrameRate = float(settings.fps);
  param.iTemporalLayerNum = 1;
  param.iSpatialLayerNum = 1;
  // Medium complexity unless the settings name another: measured at 640x360, 1.5 Mbit/s, it
  // gave 0.65 dB more than low (44.2 against 43.5 dB) for about 20% more time (1.9 against
  // 1.6 ms a frame on one core); high gave the same as medium.
  param.iComplexityMode =
      settings.speed >= 0 && settings.speed <= 2 ? static_cast<ECOMPLEXITY_MODE>(settings.speed)
                                                 : MEDIUM_COMPLEXITY;
  // Key frames as for VP8/VP9: on request, and one every 10 s (uiIntraPeriod counts frames).
  param.uiIntraPeriod = settings.keyInterval != 0 ? settings.keyInterval : settings.fps * 10;
  param.iNumRefFrame = 1;
  // One SPS/PPS for the whole stream: the MP4 init segment (avcC) is built from the first.
  param.eSpsPpsIdStrategy = CONSTANT_ID;
  param.bPrefixNalAddingCtrl = false;
  param.bEnableSSEI = false;
  param.bSimulcastAVC = false;
  param.iPaddingFlag = 0;
  param.iEntropyCodingModeFlag = 0;  // CAVLC: Baseline has no CABAC
  param.bEnableFrameSkip = false;    // every rendered frame is sent, as for libvpx
  param.bEnableLongTermReference = false;
  param.iMultipleThreadIdc = static_cast<unsigned short>(settings.threads);
  param.bUseLoadBalancing = false;  // fixed slices: the same bitstream for the same input
  param.iLoopFilterDisableIdc = 0;
  param.bEnableDenoise = false;  // rendered pictures have no sensor noise
  param.bEnableBackgroundDetection = true;
  param.bEnableAdaptiveQuant = true;
  param.bEnableFrameCroppingFlag = true;  // sizes that are not multiples of 16
  param.bEnableSceneChangeDetect = true;
  SSpatialLayerConfig& layer = param.sSpatialLayers[0];
  layer.iVideoWidth = param.iPicWidth;
  layer.iVideoHeight = param.iPicHeight;
  layer.fFrameRate = param.fMaxFrameRate;
  layer.iSpatialBitrate = param.iTargetBitrate;
  layer.iMaxSpatialBitrate = UNSPECIFIED_BIT_RATE;
  layer.uiProfileIdc = PRO_BASELINE;
  layer.uiLevelIdc = static_cast<ELevelIdc>(level);
  // One slice per thread: OpenH264 encodes slices in parallel (one slice: one thread).
  if (settings.threads > 1) {
    layer.sSliceArgument.uiSliceMode = SM_FIXEDSLCNUM_SLICE;
    layer.sSliceArgument.uiSliceNum = settings.threads;
  } else {
    layer.sSliceArgument.uiSliceMode = SM_SINGLE_SLICE;
    layer.sSliceArgument.uiSliceNum = 1;
  }
  // What rgbaToI420 makes: BT.601 (SMPTE 170M) studio range.
  layer.bVideoSignalTypePresent = true;
  layer.uiVideoFormat = 5;  // unspecified
  layer.bFullRange = false;
  layer.bColorDescriptionPresent = true;
  layer.uiColorPrimaries = 6;           // SMPTE 170M
  layer.uiTransferCharacteristics = 6;  // SMPTE 170M
  layer.uiColorMatrix = 6;              // SMPTE 170M (BT.601)

  if (const int rc = encoder->InitializeExt(&param); rc != cmResultSuccess) {
    throw VideoError(codecMessage("OpenH264 refused the encoder settings", rc));
  }
  impl_->initialized = true;
  int format = videoFormatI420;
  encoder->SetOption(ENCODER_OPTION_DATAFORMAT, &format);
  impl_->width = settings.width;
  impl_->height = settings.height;
  const size_t lumaBytes = size_t(settings.width) * settings.height;
  impl_->planes.resize(lumaBytes + 2 * (lumaBytes / 4));
}

H264Encoder::~H264Encoder() = default;

void H264Encoder::setBitrate(uint32_t kbps) {
  SBitrateInfo info{};
  info.iLayer = SPATIAL_LAYER_ALL;
  info.iBitrate = int(kbps * 1000);
  if (const int rc = impl_->encoder->SetOption(ENCODER_OPTION_BITRATE, &info);
      rc != cmResultSuccess) {
    throw VideoError(codecMessage("OpenH264 refused the new bitrate", rc));
  }
}

VideoPacket H264Encoder::encode(std::span<const uint8_t> rgba, uint64_t timestampMs,
                                bool forceKey) {
  const uint32_t w = impl_->width, h = impl_->height;
  uint8_t* y = impl_->planes.data();
  uint8_t* u = y + size_t(w) * h;
  uint8_t* v = u + size_t(w / 2) * (h / 2);
  rgbaToI420(rgba, w, h, y, w, u, w / 2, v, w / 2);
  SSourcePicture picture{};
  picture.iColorFormat = videoFormatI420;
  picture.iPicWidth = int(w);
  picture.iPicHeight = int(h);
  picture.iStride[0] = int(w);
  picture.iStride[1] = picture.iStride[2] = int(w / 2);
  picture.pData[0] = y;
  picture.pData[1] = u;
  picture.pData[2] = v;
  picture.uiTimeStamp = static_cast<long long>(timestampMs);
  if (forceKey) impl_->encoder->ForceIntraFrame(true);
  SFrameBSInfo info{};
  if (const int rc = impl_->encoder->EncodeFrame(&picture, &info); rc != cmResultSuccess) {
    throw VideoError(codecMessage("OpenH264 could not encode a frame", rc));
  }
  if (info.eFrameType == videoFrameTypeSkip || info.eFrameType == videoFrameTypeInvalid) {
    // Frame skipping is off; a skip would leave the stream a frame short.
    throw VideoError("OpenH264 returned no picture for frame " + std::to_string(impl_->frames));
  }
  VideoPacket packet;
  packet.data.reserve(size_t(std::max(info.iFrameSizeInBytes, 0)));
  for (int l = 0; l < info.iLayerNum; ++l) {
    const SLayerBSInfo& layerInfo = info.sLayerInfo[l];
    size_t bytes = 0;
    for (int n = 0; n < layerInfo.iNalCount; ++n) bytes += size_t(layerInfo.pNalLengthInByte[n]);
    packet.data.insert(packet.data.end(), layerInfo.pBsBuf, layerInfo.pBsBuf + bytes);
  }
  packet.key = info.eFrameType == videoFrameTypeIDR;
  ++impl_->frames;
  return packet;
}

// ---- Decoder.

struct H264Decoder::Impl {
  ISVCDecoder* decoder = nullptr;
  bool initialized = false;
  ~Impl() {
    if (decoder == nullptr) return;
    if (initialized) decoder->Uninitialize();
    WelsDestroyDecoder(decoder);
  }
};

H264Decoder::H264Decoder() : impl_(std::make_unique<Impl>()) {
  if (WelsCreateDecoder(&impl_->decoder) != 0 || impl_->decoder == nullptr) {
    throw VideoError("OpenH264 could not make a decoder");
  }
  int trace = WELS_LOG_QUIET;
  impl_->decoder->SetOption(DECODER_OPTION_TRACE_LEVEL, &trace);
  SDecodingParam param{};
  param.sVideoProperty.eVideoBsType = VIDEO_BITSTREAM_AVC;
  if (impl_->decoder->Initialize(&param) != 0) throw VideoError("OpenH264 refused the decoder");
  impl_->initialized = true;
}

H264Decoder::~H264Decoder() = default;

VideoDecoder::Picture H264Decoder::decode(std::span<const uint8_t> packet) {
  unsigned char* planes[3] = {nullptr, nullptr, nullptr};
  SBufferInfo info{};
  const DECODING_STATE state =
      impl_->decoder->DecodeFrameNoDelay(packet.data(), int(packet.size()), planes, &info);
  if (state != dsErrorFree) {
    throw VideoError("OpenH264 could not decode a packet (state " + std::to_string(int(state)) +
                     ")");
  }
  if (info.iBufferStatus != 1) throw VideoError("the packet decoded to no picture");
  const SSysMEMBuffer& buffer = info.UsrData.sSystemBuffer;
  VideoDecoder::Picture picture;
  picture.width = uint32_t(buffer.iWidth);
  picture.height = uint32_t(buffer.iHeight);
  picture.rgba.resize(size_t(picture.width) * picture.height * 4);
  i420ToRgba(planes[0], size_t(buffer.iStride[0]), planes[1], size_t(buffer.iStride[1]), planes[2],
             size_t(buffer.iStride[1]), picture.width, picture.height, picture.rgba.data());
  return picture;
}

}  // namespace myriad::encode
