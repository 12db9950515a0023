// `kinect3d report match`: the page a person reads after a match (docs/match-log.md), from a match
// log: which source saw the ball when, the ball's height, each flight from above and from the side
// with what the trajectory predicted (and the truth, for a simulated run), each plugin's rate,
// processing time and dropped frames, and the events. Charts are drawn by Chart.js (Debian's
// libjs-chart.js, copied beside the page so the folder stands alone).
#pragma once

#include <string>

namespace kinect3d {

// Writes out_dir/index.html, out_dir/match_data.js and out_dir/chart.min.js (chart_page.h).
void writeMatchReport(const std::string& log_folder, const std::string& out_dir);

}  // namespace kinect3d
