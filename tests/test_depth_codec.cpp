// The match log's depth codec (matchlog/depth_codec.h): lossless on any image, smaller than PNG and
// than the row differences it replaced on simulated and real frames, and refusing damaged bytes with
// their reason; the older logs' row differences still round-trip.
#include <gtest/gtest.h>
#include <zstd.h>

#include <array>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "kinect3d/sim/kinect_simulator.h"
#include "matchlog/depth_codec.h"
#include "real_data.h"

namespace {

std::vector<std::uint16_t> roundTrip(const std::vector<std::uint16_t>& depth_mm, int width, int height,
                                     fw::DepthCodec codec = fw::DepthCodec::kZstdPalette) {
  fw::DepthEncoder encoder(codec);
  const fw::DepthEncoder::Bytes bytes = encoder.encode(depth_mm.data(), width, height);
  std::vector<std::uint16_t> decoded;
  fw::decodeDepth(codec, bytes.data, bytes.size, width, height, decoded);
  return decoded;
}

std::size_t pngSize(const std::vector<std::uint16_t>& depth_mm, int width, int height) {
  std::vector<unsigned char> png;
  cv::imencode(".png", cv::Mat(height, width, CV_16UC1, const_cast<std::uint16_t*>(depth_mm.data())), png,
               {cv::IMWRITE_PNG_COMPRESSION, 1});
  return png.size();
}

std::size_t encodedSize(const std::vector<std::uint16_t>& depth_mm, int width, int height,
                        fw::DepthCodec codec = fw::DepthCodec::kZstdPalette) {
  fw::DepthEncoder encoder(codec);
  return encoder.encode(depth_mm.data(), width, height).size;
}

// What the log's codec must beat on a frame of a depth sensor: PNG, and the row differences of
// versions 5 to 9 (lossless both).
void expectSmallerThanTheCodecsBefore(const std::vector<std::uint16_t>& depth_mm, int width, int height,
                                      const std::string& frame) {
  EXPECT_EQ(roundTrip(depth_mm, width, height), depth_mm) << frame;
  EXPECT_EQ(roundTrip(depth_mm, width, height, fw::DepthCodec::kZstdRowDelta), depth_mm) << frame;
  const std::size_t size = encodedSize(depth_mm, width, height);
  EXPECT_LT(size, pngSize(depth_mm, width, height)) << frame;
  EXPECT_LT(size, encodedSize(depth_mm, width, height, fw::DepthCodec::kZstdRowDelta)) << frame;
}

TEST(DepthCodec, EveryValueAndEveryStepComesBackExactly) {
  std::mt19937 random(7);
  for (const auto& [width, height] : {std::pair{640, 480}, {8, 8}, {33, 17}, {1, 1}}) {
    const std::size_t pixels = static_cast<std::size_t>(width) * height;
    std::vector<std::vector<std::uint16_t>> images(6, std::vector<std::uint16_t>(pixels));
    for (std::size_t i = 0; i < pixels; ++i) {
      images[0][i] = static_cast<std::uint16_t>(random());                        // anything
      images[1][i] = i % 2 == 0 ? 0 : 65535;                                      // the widest steps both ways
      images[2][i] = static_cast<std::uint16_t>(i % 3 == 0 ? 0 : 32768 + i % 5);  // a jump of exactly half the range
      images[3][i] = static_cast<std::uint16_t>(800 + i % 7000);                  // a ramp
      images[4][i] = static_cast<std::uint16_t>(i % 65536);                       // every value there is
      // Palette steps of exactly one signed byte and one more, both ways.
      images[5][i] = static_cast<std::uint16_t>(std::array{0, 127, 0, 128, 1, 129, 0}[i % 7]);
    }
    for (std::size_t k = 0; k < images.size(); ++k) {
      for (const fw::DepthCodec codec : {fw::DepthCodec::kZstdPalette, fw::DepthCodec::kZstdRowDelta}) {
        EXPECT_EQ(roundTrip(images[k], width, height, codec), images[k])
            << width << "x" << height << ", image " << k << ", codec " << int(codec);
      }
    }
  }
  // One encoder for many frames (as the log uses it): each comes back, not the one before.
  fw::DepthEncoder encoder;
  for (std::uint16_t fill : {std::uint16_t(1000), std::uint16_t(0), std::uint16_t(4321)}) {
    const std::vector<std::uint16_t> image(64 * 48, fill);
    const fw::DepthEncoder::Bytes bytes = encoder.encode(image.data(), 64, 48);
    std::vector<std::uint16_t> decoded;
    fw::decodeDepth(fw::DepthCodec::kZstdPalette, bytes.data, bytes.size, 64, 48, decoded);
    EXPECT_EQ(decoded, image) << fill;
  }
}

// Simulated frames of busy scenes on sensor units from quiet to twice as noisy as the noise model:
// noise is what makes depth hard to compress.
TEST(DepthCodec, SimulatedFramesComeBackExactlyInLessSpaceThanBefore) {
  std::mt19937 random(11);
  for (const char* name : {"kick_away", "clutter", "people_no_ball_3", "corners_doors"}) {
    kinect3d::sim::Scene scene = kinect3d::sim::loadScene(name);
    scene.noise.axial_noise_scale = std::uniform_real_distribution<double>(0.5, 2.0)(random);
    kinect3d::sim::KinectSimulator simulator(scene);
    kinect3d::DepthFrame frame;
    kinect3d::sim::GroundTruth truth;
    simulator.render(simulator.frameCount() / 2, frame, truth);
    expectSmallerThanTheCodecsBefore(frame.depth_mm, frame.intrinsics.width, frame.intrinsics.height,
                                     std::string(name) + ", noise x" + std::to_string(scene.noise.axial_noise_scale));
  }
}

TEST(DepthCodec, RealFramesComeBackExactlyInLessSpaceThanBefore) {
  const std::vector<std::string> files = {
      "realdata/pcl_single_frames/five_people_depth_mm.png", "realdata/pcl_single_frames/office1_depth_mm.png",
      "realdata/pcl_grabber_sequences/frame_20121214T142255.814212_depth.tiff", "real-depth/tum_depth.png"};
  for (const std::string& file : files) {
    if (!realDataFile(file)) GTEST_SKIP() << noRealData(file);
  }
  for (const std::string& file : files) {
    const cv::Mat image = cv::imread(*realDataFile(file), cv::IMREAD_ANYDEPTH);
    ASSERT_EQ(image.type(), CV_16UC1) << file;
    const std::vector<std::uint16_t> depth(image.ptr<std::uint16_t>(), image.ptr<std::uint16_t>() + image.total());
    expectSmallerThanTheCodecsBefore(depth, image.cols, image.rows, file);
  }
}

std::string decodeError(const std::vector<std::uint8_t>& bytes, int width, int height,
                        fw::DepthCodec codec = fw::DepthCodec::kZstdPalette) {
  try {
    std::vector<std::uint16_t> decoded;
    fw::decodeDepth(codec, bytes.data(), bytes.size(), width, height, decoded);
  } catch (const fw::DepthCodecError& e) {
    return e.what();
  }
  return "no error";
}

// A palette frame as a damaged or foreign writer might make it: a palette of `count` (whatever the
// depths given), then the codes, zstd-compressed.
std::vector<std::uint8_t> paletteFrame(std::uint32_t count, const std::vector<std::uint16_t>& palette,
                                       const std::vector<std::uint8_t>& codes) {
  std::vector<std::uint8_t> plain(4);
  std::memcpy(plain.data(), &count, 4);
  for (const std::uint16_t depth : palette)
    plain.insert(plain.end(), {std::uint8_t(depth & 0xff), std::uint8_t(depth >> 8)});
  plain.insert(plain.end(), codes.begin(), codes.end());
  std::vector<std::uint8_t> bytes(ZSTD_compressBound(plain.size()));
  bytes.resize(ZSTD_compress(bytes.data(), bytes.size(), plain.data(), plain.size(), 1));
  return bytes;
}

TEST(DepthCodec, DamagedBytesAreRefusedWithTheirReason) {
  const std::vector<std::uint16_t> image(64 * 48, 1500);
  fw::DepthEncoder encoder;
  const fw::DepthEncoder::Bytes encoded = encoder.encode(image.data(), 64, 48);
  const std::vector<std::uint8_t> bytes(encoded.data, encoded.data + encoded.size);
  EXPECT_EQ(decodeError(bytes, 64, 48), "no error");
  EXPECT_EQ(decodeError({}, 64, 48), "empty");
  EXPECT_EQ(decodeError({0x0b, 0xad, 0xc0, 0xde}, 64, 48), "not zstd-compressed");
  // Another size than the row says: refused before anything is allocated when the bytes cannot hold
  // it, else when the pixels run out or are left over.
  EXPECT_EQ(decodeError(bytes, 4096, 4096), "not a 4096x4096 image (3078 bytes)");
  EXPECT_EQ(decodeError(bytes, 32, 48), "not a 32x48 image (it holds more pixels)");
  EXPECT_EQ(decodeError(paletteFrame(1, {1500}, {0, 0, 0, 0x80, 0}), 2, 2), "damaged (its last index cut)");
  std::vector<std::uint8_t> ten_escapes;
  for (int i = 0; i < 10; ++i) ten_escapes.insert(ten_escapes.end(), {0x80, 0, 0});
  EXPECT_EQ(decodeError(paletteFrame(1, {1500}, ten_escapes), 4, 4), "not a 4x4 image (it holds fewer pixels)");
  EXPECT_EQ(decodeError(paletteFrame(1, {1500}, ten_escapes), 2, 5), "no error");
  // Indices and palettes that cannot be.
  EXPECT_EQ(decodeError(paletteFrame(1, {1500}, {0, 0, 1, 0}), 2, 2),
            "damaged (palette index 1, not below its size 1)");
  EXPECT_EQ(decodeError(paletteFrame(1, {1500}, {0, 0xff, 0, 0}), 2, 2),
            "damaged (palette index -1, not below its size 1)");
  EXPECT_EQ(decodeError(paletteFrame(70000, {1500}, {0, 0, 0, 0}), 2, 2), "damaged (a palette of 70000 depths)");
  EXPECT_EQ(decodeError(paletteFrame(0, {}, {0, 0, 0, 0, 0, 0}), 2, 2), "damaged (a palette of 0 depths)");
  const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + bytes.size() / 2);
  EXPECT_EQ(decodeError(cut, 64, 48).rfind("damaged (", 0), 0u) << decodeError(cut, 64, 48);
  EXPECT_EQ(decodeError(bytes, 64, 48, fw::DepthCodec::kPng), "not a 64x48 16-bit PNG");

  // The row differences of versions 5 to 9: their size is exactly the image's.
  fw::DepthEncoder row_differences(fw::DepthCodec::kZstdRowDelta);
  const fw::DepthEncoder::Bytes old = row_differences.encode(image.data(), 64, 48);
  const std::vector<std::uint8_t> old_bytes(old.data, old.data + old.size);
  const auto oldError = [&](int width, int height) {
    return decodeError(old_bytes, width, height, fw::DepthCodec::kZstdRowDelta);
  };
  EXPECT_EQ(oldError(64, 48), "no error");
  EXPECT_EQ(oldError(4096, 4096), "not a 4096x4096 image (6144 bytes)");
  EXPECT_EQ(oldError(32, 48), "not a 32x48 image (6144 bytes)");
}

}  // namespace
