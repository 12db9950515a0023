#include "calibration_plot.h"

#include <nlohmann/json.hpp>

#include "chart_page.h"

namespace kinect3d {

extern const std::string kCalibrationPage;  // calibration_plot/index.html, built in

void writeCalibrationPlot(const PoseCalibration& calibration, const std::string& out_dir) {
  constexpr double kViewLine_m = 1.5;  // how far the sensor's view is drawn
  const Eigen::Isometry3d T_R_S = calibration.result.pose.T_R_S();
  const Eigen::Vector3d sensor = T_R_S.translation();
  const Eigen::Vector3d view = sensor + T_R_S.linear().col(2) * kViewLine_m;
  nlohmann::json marks = nlohmann::json::array();
  for (std::size_t i = 0; i < calibration.marks.size(); ++i) {
    const CalibrationMark& mark = calibration.marks[i];
    const Eigen::Vector3d seen = T_R_S * mark.ball_S_m;
    marks.push_back({{"label", std::to_string(i + 1)},
                     {"x_m", mark.ball_R_m.x()},
                     {"y_m", mark.ball_R_m.y()},
                     {"seen_x_m", seen.x()},
                     {"seen_y_m", seen.y()},
                     {"residual_m", calibration.result.residuals_m[i]},
                     {"used", static_cast<bool>(calibration.result.used[i])}});
  }
  const nlohmann::json data = {
      {"pose", fw::poseInRobotYaml(calibration.result.pose)},
      {"sensor", {{"x_m", sensor.x()}, {"y_m", sensor.y()}, {"view_x_m", view.x()}, {"view_y_m", view.y()}}},
      {"marks", marks}};
  writeChartPage(out_dir, kCalibrationPage, "calibration_data.js", "CALIBRATION", data.dump());
}

}  // namespace kinect3d
