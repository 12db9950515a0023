#include "matchlog/depth_codec.h"

#include <zstd.h>

#include <cstring>
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

// kZstdPalette: a step of the palette index beyond one signed byte is this byte and the index.
constexpr std::uint8_t kPaletteEscape = 0x80;
constexpr std::size_t kDepthValues = 65536;
// The most bytes a palette frame holds before zstd: its size, every depth value, three bytes a pixel.
std::size_t maxPaletteBytes(std::size_t pixels) { return 4 + 2 * kDepthValues + 3 * pixels; }

inline std::uint8_t* put16(std::uint8_t* out, std::uint16_t value) {
  std::memcpy(out, &value, 2);
  return out + 2;
}
inline std::uint16_t get16(const std::uint8_t* in) {
  std::uint16_t value;
  std::memcpy(&value, in, 2);
  return value;
}

// zstd's frame, decompressed whole after its claimed size has been checked against what a
// width x height image of the codec can be.
std::vector<std::uint8_t> decompress(const std::uint8_t* bytes, std::size_t size, int width, int height,
                                     std::size_t min_size, std::size_t max_size) {
  const unsigned long long claimed = ZSTD_getFrameContentSize(bytes, size);
  if (claimed == ZSTD_CONTENTSIZE_ERROR) throw DepthCodecError("not zstd-compressed");
  if (claimed == ZSTD_CONTENTSIZE_UNKNOWN || claimed < min_size || claimed > max_size) {
    throw DepthCodecError(
        "not a " + sizeText(width, height) + " image (" +
        (claimed == ZSTD_CONTENTSIZE_UNKNOWN ? std::string("no size given") : std::to_string(claimed) + " bytes") +
        ")");
  }
  std::vector<std::uint8_t> plain(claimed);
  const std::size_t written = ZSTD_decompress(plain.data(), plain.size(), bytes, size);
  if (ZSTD_isError(written)) throw DepthCodecError(std::string("damaged (") + ZSTD_getErrorName(written) + ")");
  if (written != plain.size()) throw DepthCodecError("damaged (" + std::to_string(written) + " bytes decompressed)");
  return plain;
}

void decodeZstdPalette(const std::uint8_t* bytes, std::size_t size, int width, int height,
                       std::vector<std::uint16_t>& depth_mm) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  // At least one depth in the palette and a byte a pixel.
  const std::vector<std::uint8_t> plain =
      decompress(bytes, size, width, height, 4 + 2 + pixels, maxPaletteBytes(pixels));
  std::uint32_t count;
  std::memcpy(&count, plain.data(), 4);
  if (count == 0 || count > kDepthValues || 4 + 2 * std::size_t(count) > plain.size()) {
    throw DepthCodecError("damaged (a palette of " + std::to_string(count) + " depths)");
  }
  const std::uint8_t* palette = plain.data() + 4;
  const std::uint8_t* code = palette + 2 * std::size_t(count);
  const std::uint8_t* const end = plain.data() + plain.size();
  const auto notThisImage = [&](const char* why) {
    return DepthCodecError("not a " + sizeText(width, height) + " image (" + why + ")");
  };
  depth_mm.resize(pixels);
  std::uint16_t* out = depth_mm.data();
  for (int v = 0; v < height; ++v) {
    std::int64_t left = 0;
    for (int u = 0; u < width; ++u) {
      if (code == end) throw notThisImage("it holds fewer pixels");
      std::int64_t index;
      if (*code == kPaletteEscape) {
        if (end - code < 3) throw DepthCodecError("damaged (its last index cut)");
        index = get16(code + 1);
        code += 3;
      } else {
        index = left + static_cast<std::int8_t>(*code++);
      }
      if (index < 0 || index >= count) {
        throw DepthCodecError("damaged (palette index " + std::to_string(index) + ", not below its size " +
                              std::to_string(count) + ")");
      }
      *out++ = get16(palette + 2 * index);
      left = index;
    }
  }
  if (code != end) throw notThisImage("it holds more pixels");
}

void decodeZstdRowDelta(const std::uint8_t* bytes, std::size_t size, int width, int height,
                        std::vector<std::uint16_t>& depth_mm) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  const std::vector<std::uint8_t> plain = decompress(bytes, size, width, height, pixels * 2, pixels * 2);
  depth_mm.resize(pixels);
  for (std::size_t i = 0; i < pixels; ++i) depth_mm[i] = get16(plain.data() + 2 * i);
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

DepthEncoder::DepthEncoder(DepthCodec codec, int zstd_level)
    : codec_(codec), zstd_level_(zstd_level), context_(ZSTD_createCCtx()) {
  if (codec == DepthCodec::kPng) throw std::invalid_argument("the depth encoder writes zstd; PNG is only read");
  if (context_ == nullptr) throw std::bad_alloc();
}

DepthEncoder::~DepthEncoder() { ZSTD_freeCCtx(context_); }

std::size_t DepthEncoder::paletteCodes(const std::uint16_t* depth_mm, int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  palette_codes_.resize(maxPaletteBytes(pixels));
  // Which depths the frame holds (1), then each one's rank among them.
  palette_index_.assign(kDepthValues, 0);
  for (std::size_t i = 0; i < pixels; ++i) palette_index_[depth_mm[i]] = 1;
  std::uint8_t* out = palette_codes_.data() + 4;
  std::uint32_t count = 0;
  for (std::size_t value = 0; value < kDepthValues; ++value) {
    if (palette_index_[value] == 0) continue;
    palette_index_[value] = static_cast<std::uint16_t>(count++);
    out = put16(out, static_cast<std::uint16_t>(value));
  }
  std::memcpy(palette_codes_.data(), &count, 4);
  for (int v = 0; v < height; ++v) {
    const std::uint16_t* row = depth_mm + static_cast<std::size_t>(v) * width;
    int left = 0;
    for (int u = 0; u < width; ++u) {
      const int index = palette_index_[row[u]];
      const int step = index - left;
      if (step >= -127 && step <= 127) {
        *out++ = static_cast<std::uint8_t>(step);
      } else {
        *out++ = kPaletteEscape;
        out = put16(out, static_cast<std::uint16_t>(index));
      }
      left = index;
    }
  }
  return static_cast<std::size_t>(out - palette_codes_.data());
}

DepthEncoder::Bytes DepthEncoder::encode(const std::uint16_t* depth_mm, int width, int height) {
  const void* plain = nullptr;
  std::size_t plain_size = 0;
  if (codec_ == DepthCodec::kZstdPalette) {
    plain_size = paletteCodes(depth_mm, width, height);
    plain = palette_codes_.data();
  } else {
    residuals_.resize(static_cast<std::size_t>(width) * height);
    rowDeltaResiduals(depth_mm, width, height, residuals_.data());
    plain_size = residuals_.size() * 2;
    plain = residuals_.data();
  }
  compressed_.resize(ZSTD_compressBound(plain_size));
  const std::size_t size =
      ZSTD_compressCCtx(context_, compressed_.data(), compressed_.size(), plain, plain_size, zstd_level_);
  // With a buffer of zstd's own bound, only running out of memory makes it fail.
  if (ZSTD_isError(size)) throw std::bad_alloc();
  return {compressed_.data(), size};
}

void decodeDepth(DepthCodec codec, const std::uint8_t* bytes, std::size_t size, int width, int height,
                 std::vector<std::uint16_t>& depth_mm) {
  if (size == 0) throw DepthCodecError("empty");
  switch (codec) {
    case DepthCodec::kZstdPalette:
      decodeZstdPalette(bytes, size, width, height, depth_mm);
      return;
    case DepthCodec::kZstdRowDelta:
      decodeZstdRowDelta(bytes, size, width, height, depth_mm);
      return;
    case DepthCodec::kPng:
      decodePng(bytes, size, width, height, depth_mm);
      return;
  }
}

}  // namespace fw
