// A page drawn by Chart.js that a person opens from a folder: the page, its data as a script, and
// Chart.js itself (copied from Debian's libjs-chart.js, so the folder can go to another laptop).
#pragma once

#include <string>

namespace kinect3d {

// Writes out_dir/index.html (page), out_dir/<data_file> ("const <variable> = <json>;") and
// out_dir/chart.min.js. Throws std::runtime_error naming a file it cannot write.
void writeChartPage(const std::string& out_dir, const std::string& page, const std::string& data_file,
                    const std::string& variable, const std::string& json);

}  // namespace kinect3d
