// The match log's depth codec (kinect3d/depth_codec.h): lossless on any image, no larger than the
// PNG it replaced on simulated and real frames, and refusing damaged bytes with their reason.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>

#include "kinect3d/sim/kinect_simulator.h"
#include "matchlog/depth_codec.h"
#include "real_data.h"

namespace {

std::vector<std::uint16_t> roundTrip(const std::vector<std::uint16_t>& depth_mm, int width, int height) {
  fw::DepthEncoder encoder;
  const fw::DepthEncoder::Bytes bytes = encoder.encode(depth_mm.data(), width, height);
  std::vector<std::uint16_t> decoded;
  fw::decodeDepth(fw::DepthCodec::kZstdRowDelta, bytes.data, bytes.size, width, height, decoded);
  return decoded;
}

std::size_t pngSize(const std::vector<std::uint16_t>& depth_mm, int width, int height) {
  std::vector<unsigned char> png;
  cv::imencode(".png", cv::Mat(height, width, CV_16UC1, const_cast<std::uint16_t*>(depth_mm.data())), png,
               {cv::IMWRITE_PNG_COMPRESSION, 1});
  return png.size();
}

std::size_t encodedSize(const std::vector<std::uint16_t>& depth_mm, int width, int height) {
  fw::DepthEncoder encoder;
  return encoder.encode(depth_mm.data(), width, height).size;
}

TEST(DepthCodec, EveryValueAndEveryStepComesBackExactly) {
  std::mt19937 random(7);
  for (const auto& [width, height] : {std::pair{640, 480}, {8, 8}, {33, 17}}) {
    const std::size_t pixels = static_cast<std::size_t>(width) * height;
    std::vector<std::vector<std::uint16_t>> images(4, std::vector<std::uint16_t>(pixels));
    for (std::size_t i = 0; i < pixels; ++i) {
      images[0][i] = static_cast<std::uint16_t>(random());                        // anything
      images[1][i] = i % 2 == 0 ? 0 : 65535;                                      // the widest steps both ways
      images[2][i] = static_cast<std::uint16_t>(i % 3 == 0 ? 0 : 32768 + i % 5);  // a jump of exactly half the range
      images[3][i] = static_cast<std::uint16_t>(800 + i % 7000);                  // a ramp
    }
    for (std::size_t k = 0; k < images.size(); ++k) {
      EXPECT_EQ(roundTrip(images[k], width, height), images[k]) << width << "x" << height << ", image " << k;
    }
  }
  // One encoder for many frames (as the log uses it): each comes back, not the one before.
  fw::DepthEncoder encoder;
  for (std::uint16_t fill : {std::uint16_t(1000), std::uint16_t(0), std::uint16_t(4321)}) {
    const std::vector<std::uint16_t> image(64 * 48, fill);
    const fw::DepthEncoder::Bytes bytes = encoder.encode(image.data(), 64, 48);
    std::vector<std::uint16_t> decoded;
    fw::decodeDepth(fw::DepthCodec::kZstdRowDelta, bytes.data, bytes.size, 64, 48, decoded);
    EXPECT_EQ(decoded, image) << fill;
  }
}

// Simulated frames of busy scenes on sensor units from quiet to twice as noisy as the noise model:
// noise is what makes depth hard to compress.
TEST(DepthCodec, SimulatedFramesComeBackExactlyInLessSpaceThanPng) {
  std::mt19937 random(11);
  for (const char* name : {"kick_away", "clutter", "people_no_ball_3", "corners_doors"}) {
    kinect3d::sim::Scene scene = kinect3d::sim::loadScene(name);
    scene.noise.axial_noise_scale = std::uniform_real_distribution<double>(0.5, 2.0)(random);
    kinect3d::sim::KinectSimulator simulator(scene);
    kinect3d::DepthFrame frame;
    kinect3d::sim::GroundTruth truth;
    simulator.render(simulator.frameCount() / 2, frame, truth);
    const int width = frame.intrinsics.width, height = frame.intrinsics.height;
    EXPECT_EQ(roundTrip(frame.depth_mm, width, height), frame.depth_mm) << name;
    EXPECT_LT(encodedSize(frame.depth_mm, width, height), pngSize(frame.depth_mm, width, height))
        << name << ", noise x" << scene.noise.axial_noise_scale;
  }
}

TEST(DepthCodec, RealFramesComeBackExactlyInLessSpaceThanPng) {
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
    EXPECT_EQ(roundTrip(depth, image.cols, image.rows), depth) << file;
    EXPECT_LT(encodedSize(depth, image.cols, image.rows), pngSize(depth, image.cols, image.rows)) << file;
  }
}

std::string decodeError(const std::vector<std::uint8_t>& bytes, int width, int height,
                        fw::DepthCodec codec = fw::DepthCodec::kZstdRowDelta) {
  try {
    std::vector<std::uint16_t> decoded;
    fw::decodeDepth(codec, bytes.data(), bytes.size(), width, height, decoded);
  } catch (const fw::DepthCodecError& e) {
    return e.what();
  }
  return "no error";
}

TEST(DepthCodec, DamagedBytesAreRefusedWithTheirReason) {
  const std::vector<std::uint16_t> image(64 * 48, 1500);
  fw::DepthEncoder encoder;
  const fw::DepthEncoder::Bytes encoded = encoder.encode(image.data(), 64, 48);
  const std::vector<std::uint8_t> bytes(encoded.data, encoded.data + encoded.size);
  EXPECT_EQ(decodeError({}, 64, 48), "empty");
  EXPECT_EQ(decodeError({0x0b, 0xad, 0xc0, 0xde}, 64, 48), "not zstd-compressed");
  // Another size than the row says, larger or smaller: refused before anything is allocated.
  EXPECT_EQ(decodeError(bytes, 4096, 4096), "not a 4096x4096 image (6144 bytes)");
  EXPECT_EQ(decodeError(bytes, 32, 48), "not a 32x48 image (6144 bytes)");
  const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + bytes.size() / 2);
  EXPECT_EQ(decodeError(cut, 64, 48).rfind("damaged (", 0), 0u) << decodeError(cut, 64, 48);
  EXPECT_EQ(decodeError(bytes, 64, 48, fw::DepthCodec::kPng), "not a 64x48 16-bit PNG");
}

}  // namespace
