#include "chart_page.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace kinect3d {

void writeChartPage(const std::string& out_dir, const std::string& page, const std::string& data_file,
                    const std::string& variable, const std::string& json) {
  namespace fs = std::filesystem;
  fs::create_directories(out_dir);
  const auto write = [&](const std::string& name, const std::string& text) {
    const fs::path path = fs::path(out_dir) / name;
    std::ofstream file(path);
    file << text;
    if (!file.flush()) throw std::runtime_error("cannot write '" + path.string() + "'");
  };
  write("index.html", page);
  write(data_file, "// Written by kinect3d: the page's data.\nconst " + variable + " = " + json + ";\n");
  std::error_code error;
  fs::copy_file(KINECT3D_CHART_JS, fs::path(out_dir) / "chart.min.js", fs::copy_options::overwrite_existing, error);
  if (error) {
    throw std::runtime_error(std::string("cannot copy Chart.js from ") + KINECT3D_CHART_JS +
                             " (Debian package libjs-chart.js): " + error.message());
  }
}

}  // namespace kinect3d
