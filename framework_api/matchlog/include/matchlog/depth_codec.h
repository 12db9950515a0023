// The match log's depth codec, lossless. A structured-light sensor's millimetres come from its
// disparity steps, so a frame holds a few hundred distinct depths: each frame's distinct depths are
// stored once, sorted (its palette), and each pixel as the difference of its palette index to its
// left neighbour's, one byte for most, compressed by zstd at level 1. Chosen by measurement over
// PNG, RVL, lz4 and zstd on the millimetres' own row differences (docs/depth-codec.md,
// `kinect3d_bench --depth-codec`). Logs of schema versions 5 to 9 hold the row differences, 2 to 4
// PNG; all decode here.
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

// zstd's fastest level that still entropy-codes well; on the palette steps level 3 is no smaller
// and up to two fifths slower (docs/depth-codec.md).
constexpr int kDepthZstdLevel = 1;

enum class DepthCodec {
  // The log's, from schema version 10. zstd-compressed: the palette's size K (u32), its K depths
  // ascending (u16 each), then each pixel row by row: its palette index minus its left neighbour's
  // (the first of a row: minus 0) as one signed byte when within +-127, else the byte 0x80 and the
  // index (u16). Little-endian.
  kZstdPalette,
  // Schema versions 5 to 9: each pixel's millimetres minus its left neighbour's (the first of a row:
  // minus 0), zigzagged (0, -1, 1, -2, ... as 0, 1, 2, 3, ...), u16 little-endian, zstd-compressed.
  kZstdRowDelta,
  kPng,  // 16-bit grey PNG (zlib level 1), schema versions 2 to 4
};

// kZstdRowDelta's transform before zstd, and its inverse in place (residuals become millimetres);
// the benchmark's lz4 row uses them too.
void rowDeltaResiduals(const std::uint16_t* depth_mm, int width, int height, std::uint16_t* residuals);
void undoRowDeltaResiduals(std::uint16_t* residuals, int width, int height);

// Encodes frames one after another, reusing its buffers: no heap allocation once it has seen a
// frame of the size.
class DepthEncoder {
 public:
  // codec: the log's, or an older zstd one for the tests of old logs and the benchmark that chose
  // the codec; kPng is not written here.
  explicit DepthEncoder(DepthCodec codec = DepthCodec::kZstdPalette, int zstd_level = kDepthZstdLevel);
  ~DepthEncoder();
  DepthEncoder(const DepthEncoder&) = delete;
  DepthEncoder& operator=(const DepthEncoder&) = delete;

  struct Bytes {
    const std::uint8_t* data;
    std::size_t size;
  };
  // Encodes width x height millimetres (0: no depth); the bytes stay valid until the next call.
  Bytes encode(const std::uint16_t* depth_mm, int width, int height);

 private:
  // kZstdPalette's bytes before zstd, into palette_codes_; returns how many.
  std::size_t paletteCodes(const std::uint16_t* depth_mm, int width, int height);

  DepthCodec codec_;
  int zstd_level_;
  ZSTD_CCtx_s* context_;
  std::vector<std::uint16_t> palette_index_;  // of each depth value, for the frame being encoded
  std::vector<std::uint8_t> palette_codes_;   // kZstdPalette's bytes before zstd
  std::vector<std::uint16_t> residuals_;      // kZstdRowDelta's
  std::vector<std::uint8_t> compressed_;
};

// Decodes bytes written by codec into depth_mm, width x height millimetres. Throws DepthCodecError
// saying what is wrong (another size, not this codec, damaged) before allocating what the bytes
// claim.
void decodeDepth(DepthCodec codec, const std::uint8_t* bytes, std::size_t size, int width, int height,
                 std::vector<std::uint16_t>& depth_mm);

}  // namespace fw
