#include "matchlog/colour_codec.h"

#include <turbojpeg.h>

#include <memory>
#include <string>

namespace fw {

namespace {

std::string sizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

struct HandleDeleter {
  void operator()(void* handle) const { tjDestroy(handle); }
};
using Handle = std::unique_ptr<void, HandleDeleter>;

}  // namespace

JpegEncoder::JpegEncoder(int quality) : quality_(quality), compressor_(nullptr) {
  if (quality < 1 || quality > 100) {
    throw ColourCodecError("a JPEG quality of " + std::to_string(quality) + " (1 to 100)");
  }
  compressor_ = tjInitCompress();
  if (compressor_ == nullptr) throw ColourCodecError(std::string("no JPEG encoder: ") + tjGetErrorStr2(nullptr));
}

JpegEncoder::~JpegEncoder() { tjDestroy(compressor_); }

JpegEncoder::Bytes JpegEncoder::encode(const std::uint8_t* rgb, int width, int height) {
  // The largest JPEG these pixels can give, so that TurboJPEG writes into this buffer and never
  // allocates its own.
  buffer_.resize(tjBufSize(width, height, TJSAMP_420));
  unsigned char* out = buffer_.data();
  unsigned long size = buffer_.size();
  // The accurate DCT, as OpenCV's encoder used: TurboJPEG's default when encoding is the fast one,
  // which loses a little more of the ball's colour.
  if (tjCompress2(compressor_, rgb, width, 0, height, TJPF_RGB, &out, &size, TJSAMP_420, quality_,
                  TJFLAG_NOREALLOC | TJFLAG_ACCURATEDCT) != 0) {
    throw ColourCodecError("a " + sizeText(width, height) +
                           " colour image did not encode: " + tjGetErrorStr2(compressor_));
  }
  return {buffer_.data(), static_cast<std::size_t>(size)};
}

void decodeJpeg(const std::uint8_t* bytes, std::size_t size, int width, int height, std::vector<std::uint8_t>& rgb) {
  const Handle decompressor(tjInitDecompress());
  if (!decompressor) throw ColourCodecError(std::string("no JPEG decoder: ") + tjGetErrorStr2(nullptr));
  const std::string not_this = "not a " + sizeText(width, height) + " colour JPEG";
  int claimed_width = 0, claimed_height = 0, subsampling = 0, colourspace = 0;
  if (tjDecompressHeader3(decompressor.get(), bytes, size, &claimed_width, &claimed_height, &subsampling,
                          &colourspace) != 0) {
    throw ColourCodecError(not_this + " (" + tjGetErrorStr2(decompressor.get()) + ")");
  }
  if (claimed_width != width || claimed_height != height) {
    throw ColourCodecError(not_this + " (it is " + sizeText(claimed_width, claimed_height) + ")");
  }
  rgb.resize(static_cast<std::size_t>(width) * height * 3);
  if (tjDecompress2(decompressor.get(), bytes, size, rgb.data(), width, 0, height, TJPF_RGB, 0) != 0 &&
      tjGetErrorCode(decompressor.get()) != TJERR_WARNING) {
    throw ColourCodecError("damaged (" + std::string(tjGetErrorStr2(decompressor.get())) + ")");
  }
}

}  // namespace fw
