// The match log's depth codec, lossless: each pixel's difference to its left neighbour (the first
// pixel of a row: to 0), zigzagged so that small steps either way are small numbers, as 16-bit
// little-endian words compressed by zstd at level 1. Chosen by measurement over PNG, RVL and lz4
// (docs/depth-codec.md, `kinect3d_bench --depth-codec`): smaller than PNG's files at a fifth of its
// time. Logs of schema versions 2 to 4 hold PNG; both decode here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

struct ZSTD_CCtx_s;

namespace fw {

// Bytes that do not decode to the image they claim to be: says why.
class DepthCodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// zstd's fastest level that still entropy-codes well; level 3 saves 0-6 % of the size for up to a
// fifth more time (docs/depth-codec.md).
constexpr int kDepthZstdLevel = 1;

enum class DepthCodec {
  kZstdRowDelta,  // the log's, from schema version 5
  kPng,           // 16-bit grey PNG (zlib level 1), schema versions 2 to 4
};

// The transform before zstd: each pixel's zigzagged difference to its left neighbour; and its
// inverse, in place (residuals become millimetres).
void rowDeltaResiduals(const std::uint16_t* depth_mm, int width, int height, std::uint16_t* residuals);
void undoRowDeltaResiduals(std::uint16_t* residuals, int width, int height);

// Encodes frames one after another, reusing its buffers: no heap allocation once it has seen a
// frame of the size.
class DepthEncoder {
 public:
  // zstd_level: the log's, or another for the benchmark that chose it.
  explicit DepthEncoder(int zstd_level = kDepthZstdLevel);
  ~DepthEncoder();
  DepthEncoder(const DepthEncoder&) = delete;
  DepthEncoder& operator=(const DepthEncoder&) = delete;

  struct Bytes {
    const std::uint8_t* data;
    std::size_t size;
  };
  // Encodes width x height millimetres (0: no depth) with DepthCodec::kZstdRowDelta; the bytes stay
  // valid until the next call.
  Bytes encode(const std::uint16_t* depth_mm, int width, int height);

 private:
  int zstd_level_;
  ZSTD_CCtx_s* context_;
  std::vector<std::uint16_t> residuals_;
  std::vector<std::uint8_t> compressed_;
};

// Decodes bytes written by codec into depth_mm, width x height millimetres. Throws DepthCodecError
// saying what is wrong (another size, not this codec, damaged) before allocating what the bytes
// claim.
void decodeDepth(DepthCodec codec, const std::uint8_t* bytes, std::size_t size, int width, int height,
                 std::vector<std::uint16_t>& depth_mm);

}  // namespace fw
