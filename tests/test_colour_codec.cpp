// The match log's colour codec (matchlog/colour_codec.h): RGB in, the same RGB out within JPEG's
// loss, the same bytes OpenCV's encoder gave for logs written before it, and damaged or foreign
// bytes refused with their reason.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "matchlog/colour_codec.h"

namespace {

constexpr int kWidth = 64, kHeight = 48;

// Left third red, middle green, right blue, with a gentle ramp down the rows: a swap of any two
// channels, or of the image's halves, shows.
std::vector<std::uint8_t> stripes() {
  std::vector<std::uint8_t> rgb(kWidth * kHeight * 3);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      std::uint8_t* px = &rgb[(v * kWidth + u) * 3];
      const int channel = u * 3 / kWidth;
      for (int c = 0; c < 3; ++c) px[c] = static_cast<std::uint8_t>(c == channel ? 200 + v / 2 : 20 + v / 4);
    }
  }
  return rgb;
}

// JPEG's loss on the stripes at quality 90: 4.2 levels on average, most of it where 4:2:0 chroma
// subsampling blurs a sharp change of colour. Two channels swapped after decoding give 81-85.
constexpr double kJpegLoss = 8.0;

double meanAbsoluteDifference(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += std::abs(int(a[i]) - int(b[i]));
  return sum / static_cast<double>(a.size());
}

std::string refusal(const std::vector<std::uint8_t>& bytes, int width, int height) {
  std::vector<std::uint8_t> rgb;
  try {
    fw::decodeJpeg(bytes.data(), bytes.size(), width, height, rgb);
  } catch (const fw::ColourCodecError& e) {
    return e.what();
  }
  return "(decoded)";
}

TEST(ColourCodec, RgbComesBackInItsOwnOrderWithinJpegsLoss) {
  const std::vector<std::uint8_t> rgb = stripes();
  fw::JpegEncoder encoder(90);
  const fw::JpegEncoder::Bytes bytes = encoder.encode(rgb.data(), kWidth, kHeight);
  std::vector<std::uint8_t> decoded;
  fw::decodeJpeg(bytes.data, bytes.size, kWidth, kHeight, decoded);
  ASSERT_EQ(decoded.size(), rgb.size());
  EXPECT_LT(meanAbsoluteDifference(decoded, rgb), kJpegLoss);
  // The middle of each stripe is its own colour.
  for (int channel = 0; channel < 3; ++channel) {
    const std::uint8_t* px = &decoded[((kHeight / 2) * kWidth + (2 * channel + 1) * kWidth / 6) * 3];
    for (int c = 0; c < 3; ++c) {
      if (c == channel) {
        EXPECT_GT(px[c], 190) << "stripe " << channel << ", channel " << c;
      } else {
        EXPECT_LT(px[c], 60) << "stripe " << channel << ", channel " << c;
      }
    }
  }
}

TEST(ColourCodec, ALowerQualityGivesFewerBytesAndABadQualityIsRefused) {
  const std::vector<std::uint8_t> rgb = stripes();
  fw::JpegEncoder low(30), high(95);
  EXPECT_LT(low.encode(rgb.data(), kWidth, kHeight).size, high.encode(rgb.data(), kWidth, kHeight).size);
  for (const int quality : {0, 101}) {
    try {
      fw::JpegEncoder encoder(quality);
      ADD_FAILURE() << "a quality of " << quality << " was taken";
    } catch (const fw::ColourCodecError& e) {
      EXPECT_NE(std::string(e.what()).find("quality of " + std::to_string(quality)), std::string::npos) << e.what();
    }
  }
}

TEST(ColourCodec, OneEncoderEncodesFramesOfAnySizeOneAfterAnother) {
  fw::JpegEncoder encoder(90);
  for (const auto& [width, height] : {std::pair{64, 48}, {640, 480}, {33, 17}, {64, 48}}) {
    const std::vector<std::uint8_t> grey(static_cast<std::size_t>(width) * height * 3, 128);
    const fw::JpegEncoder::Bytes bytes = encoder.encode(grey.data(), width, height);
    std::vector<std::uint8_t> decoded;
    fw::decodeJpeg(bytes.data, bytes.size, width, height, decoded);
    EXPECT_LT(meanAbsoluteDifference(decoded, grey), 1.0) << width << "x" << height;
  }
}

TEST(ColourCodec, LogsWrittenThroughOpenCvDecodeToTheirRgb) {
  // Before this codec the logger converted RGB to OpenCV's BGR and let imencode write the JPEG.
  const std::vector<std::uint8_t> rgb = stripes();
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(kHeight, kWidth, CV_8UC3, const_cast<std::uint8_t*>(rgb.data())), bgr, cv::COLOR_RGB2BGR);
  std::vector<unsigned char> opencv_jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, opencv_jpeg, {cv::IMWRITE_JPEG_QUALITY, 90}));
  std::vector<std::uint8_t> decoded;
  fw::decodeJpeg(opencv_jpeg.data(), opencv_jpeg.size(), kWidth, kHeight, decoded);
  EXPECT_LT(meanAbsoluteDifference(decoded, rgb), kJpegLoss);
  // And they are the same bytes: the same library, quality and subsampling underneath.
  fw::JpegEncoder encoder(90);
  const fw::JpegEncoder::Bytes bytes = encoder.encode(rgb.data(), kWidth, kHeight);
  EXPECT_EQ(std::vector<std::uint8_t>(bytes.data, bytes.data + bytes.size), opencv_jpeg);
}

TEST(ColourCodec, ForeignDamagedOrMisSizedBytesAreRefusedWithTheirReason) {
  const std::vector<std::uint8_t> rgb = stripes();
  fw::JpegEncoder encoder(90);
  const fw::JpegEncoder::Bytes bytes = encoder.encode(rgb.data(), kWidth, kHeight);
  const std::vector<std::uint8_t> jpeg(bytes.data, bytes.data + bytes.size);

  EXPECT_NE(refusal(jpeg, 32, 48).find("not a 32x48 colour JPEG (it is 64x48)"), std::string::npos)
      << refusal(jpeg, 32, 48);
  const std::vector<std::uint8_t> text = {'n', 'o', 't', ' ', 'a', ' ', 'j', 'p', 'e', 'g'};
  EXPECT_NE(refusal(text, kWidth, kHeight).find("not a 64x48 colour JPEG"), std::string::npos)
      << refusal(text, kWidth, kHeight);
  EXPECT_NE(refusal({}, kWidth, kHeight).find("not a 64x48 colour JPEG"), std::string::npos);
  // A JPEG cut short keeps what it holds: the rows before the cut decode as they were.
  const std::vector<std::uint8_t> cut(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() * 3 / 4));
  std::vector<std::uint8_t> decoded;
  ASSERT_NO_THROW(fw::decodeJpeg(cut.data(), cut.size(), kWidth, kHeight, decoded));
  const std::vector<std::uint8_t> top_rows(rgb.begin(), rgb.begin() + kWidth * 3 * 8);
  EXPECT_LT(
      meanAbsoluteDifference(std::vector<std::uint8_t>(decoded.begin(), decoded.begin() + kWidth * 3 * 8), top_rows),
      kJpegLoss);
}

}  // namespace
