#include "matchlog/match_log.h"
#include "sources.h"

namespace kinect3d {

namespace {

class LogDepthSource : public DepthSource {
 public:
  LogDepthSource(const std::string& folder, const SourceOptions& options) : DepthSource(options), log_(folder) {
    const auto sources = log_.depthSources();
    if (sources.empty()) throw DepthSourceError(folder + ": the match log holds no depth frames");
    source_ = sources.front().first;
    count_ = sources.front().second;
    frames_ = std::make_unique<fw::MatchLogReader::DepthFrames>(log_, source_);
  }

  std::uint64_t frameCount() const override { return count_; }
  std::string describe() const override {
    return "match log " + log_.folder() + " (" + std::to_string(count_) + " depth frames of '" + source_ + "')";
  }

 private:
  ReadResult readFrame(DepthFrame& frame) override {
    double wall_time_s = 0.0;
    try {
      if (!frames_->next(image_, wall_time_s)) return ReadResult::kEnd;
    } catch (const fw::MatchLogError& e) {
      throw DepthSourceError(e.what());
    }
    frame = fromDepthImage(std::move(image_));
    frame.sensor_id = "log:" + log_.folder();
    return ReadResult::kFrame;
  }

  fw::MatchLogReader log_;
  std::string source_;
  std::uint64_t count_ = 0;
  std::unique_ptr<fw::MatchLogReader::DepthFrames> frames_;
  fw::DepthImage image_;
};

}  // namespace

std::unique_ptr<DepthSource> openMatchLog(const std::string& folder, const SourceOptions& options) {
  try {
    return std::make_unique<LogDepthSource>(folder, options);
  } catch (const fw::MatchLogError& e) {
    throw DepthSourceError(e.what());
  }
}

}  // namespace kinect3d
