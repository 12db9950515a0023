#include "matchlog/depth_codec.h"

#include <zstd.h>

#include <opencv2/imgcodecs.hpp>
#include <string>

namespace fw {

namespace {

// The words are written as the CPU holds them: the format is little-endian.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the depth codec writes little-endian words");

// 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...: a step of a few millimetres either way stays a small number.
// In unsigned 16-bit arithmetic: the difference shifted left, its bits flipped when it is negative.
inline std::uint16_t zigzag(std::uint16_t difference) {
  const auto negative = static_cast<std::uint16_t>(-(difference >> 15));  // 0 or 0xffff
  return static_cast<std::uint16_t>((difference << 1) ^ negative);
}
inline std::uint16_t unzigzag(std::uint16_t z) { return static_cast<std::uint16_t>((z >> 1) ^ -(z & 1)); }

std::string sizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

void decodeZstdRowDelta(const std::uint8_t* bytes, std::size_t size, int width, int height,
                        std::vector<std::uint16_t>& depth_mm) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  const unsigned long long claimed = ZSTD_getFrameContentSize(bytes, size);
  if (claimed == ZSTD_CONTENTSIZE_ERROR) throw DepthCodecError("not zstd-compressed");
  if (claimed != pixels * 2) {
    throw DepthCodecError(
        "not a " + sizeText(width, height) + " image (" +
        (claimed == ZSTD_CONTENTSIZE_UNKNOWN ? std::string("no size given") : std::to_string(claimed) + " bytes") +
        ")");
  }
  depth_mm.resize(pixels);
  const std::size_t written = ZSTD_decompress(depth_mm.data(), pixels * 2, bytes, size);
  if (ZSTD_isError(written)) throw DepthCodecError(std::string("damaged (") + ZSTD_getErrorName(written) + ")");
  if (written != pixels * 2) throw DepthCodecError("damaged (" + std::to_string(written) + " bytes decompressed)");
  undoRowDeltaResiduals(depth_mm.data(), width, height);
}

void decodePng(const std::uint8_t* bytes, std::size_t size, int width, int height,
               std::vector<std::uint16_t>& depth_mm) {
  const std::string not_png = "not a " + sizeText(width, height) + " 16-bit PNG";
  // What the PNG itself claims (its IHDR), checked before the decoder allocates it.
  const auto bigEndian = [&](std::size_t at) {
    return size >= at + 4 ? (std::uint32_t(bytes[at]) << 24 | std::uint32_t(bytes[at + 1]) << 16 |
                             std::uint32_t(bytes[at + 2]) << 8 | bytes[at + 3])
                          : 0u;
  };
  if (bigEndian(16) != static_cast<std::uint32_t>(width) || bigEndian(20) != static_cast<std::uint32_t>(height)) {
    throw DepthCodecError(not_png);
  }
  const cv::Mat png(1, static_cast<int>(size), CV_8UC1, const_cast<std::uint8_t*>(bytes));
  const cv::Mat depth = cv::imdecode(png, cv::IMREAD_ANYDEPTH);
  if (depth.empty() || depth.type() != CV_16UC1 || depth.cols != width || depth.rows != height) {
    throw DepthCodecError(not_png);
  }
  depth_mm.assign(depth.ptr<std::uint16_t>(), depth.ptr<std::uint16_t>() + depth.total());
}

}  // namespace

void rowDeltaResiduals(const std::uint16_t* depth_mm, int width, int height, std::uint16_t* residuals) {
  for (int v = 0; v < height; ++v) {
    const std::uint16_t* row = depth_mm + static_cast<std::size_t>(v) * width;
    std::uint16_t* residual = residuals + static_cast<std::size_t>(v) * width;
    residual[0] = zigzag(row[0]);
    // Written without a carried "left" so that the compiler vectorises it.
    for (int u = 1; u < width; ++u) residual[u] = zigzag(static_cast<std::uint16_t>(row[u] - row[u - 1]));
  }
}

void undoRowDeltaResiduals(std::uint16_t* residuals, int width, int height) {
  for (int v = 0; v < height; ++v) {
    std::uint16_t* row = residuals + static_cast<std::size_t>(v) * width;
    std::uint16_t left = 0;
    for (int u = 0; u < width; ++u) row[u] = left = static_cast<std::uint16_t>(left + unzigzag(row[u]));
  }
}

DepthEncoder::DepthEncoder(int zstd_level) : zstd_level_(zstd_level), context_(ZSTD_createCCtx()) {
  if (context_ == nullptr) throw std::bad_alloc();
}

DepthEncoder::~DepthEncoder() { ZSTD_freeCCtx(context_); }

DepthEncoder::Bytes DepthEncoder::encode(const std::uint16_t* depth_mm, int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  residuals_.resize(pixels);
  rowDeltaResiduals(depth_mm, width, height, residuals_.data());
  compressed_.resize(ZSTD_compressBound(pixels * 2));
  const std::size_t size =
      ZSTD_compressCCtx(context_, compressed_.data(), compressed_.size(), residuals_.data(), pixels * 2, zstd_level_);
  // With a buffer of zstd's own bound, only running out of memory makes it fail.
  if (ZSTD_isError(size)) throw std::bad_alloc();
  return {compressed_.data(), size};
}

void decodeDepth(DepthCodec codec, const std::uint8_t* bytes, std::size_t size, int width, int height,
                 std::vector<std::uint16_t>& depth_mm) {
  if (size == 0) throw DepthCodecError("empty");
  switch (codec) {
    case DepthCodec::kZstdRowDelta:
      decodeZstdRowDelta(bytes, size, width, height, depth_mm);
      return;
    case DepthCodec::kPng:
      decodePng(bytes, size, width, height, depth_mm);
      return;
  }
}

}  // namespace fw
