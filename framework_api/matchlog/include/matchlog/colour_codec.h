// The match log's colour codec: baseline JPEG (4:2:0) by libjpeg-turbo's TurboJPEG API, straight
// from and to the RGB rows the depth plugins hand out. Through OpenCV the same bytes took 1.3 times
// as long to encode and 1.6 times to decode: a conversion to its BGR order each way, and its codec's own copies
// (docs/colour-codec.md, `kinect3d_bench --colour-codec`). Logs written through OpenCV decode here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace fw {

// Bytes that do not decode to the colour image they claim to be: says why.
class ColourCodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Encodes frames one after another into a buffer it keeps: no heap allocation once it has seen a
// frame of the size.
class JpegEncoder {
 public:
  // quality: 1 to 100 (logger.colour_jpeg_quality); another is refused.
  explicit JpegEncoder(int quality);
  ~JpegEncoder();
  JpegEncoder(const JpegEncoder&) = delete;
  JpegEncoder& operator=(const JpegEncoder&) = delete;

  struct Bytes {
    const std::uint8_t* data;
    std::size_t size;
  };
  // Encodes width x height RGB pixels (3 bytes each, rows packed); the bytes stay valid until the
  // next call.
  Bytes encode(const std::uint8_t* rgb, int width, int height);

 private:
  int quality_;
  void* compressor_;  // TurboJPEG's handle
  std::vector<std::uint8_t> buffer_;
};

// Decodes a JPEG that should hold a width x height colour image into rgb (3 bytes a pixel). Throws
// ColourCodecError saying what is wrong (not a JPEG, another size, damaged beyond decoding) before
// allocating what the bytes claim. A JPEG damaged in part (a lost segment) still decodes, its
// damaged blocks grey: what was recorded is kept.
void decodeJpeg(const std::uint8_t* bytes, std::size_t size, int width, int height, std::vector<std::uint8_t>& rgb);

}  // namespace fw
