// How the generated reports (docs/fusion-report.md, docs/team-report.md) write their figures.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace kinect3d {

// Metres to the centimetre; "-" for none (a quantile of nothing is NaN).
inline std::string metres(double value) {
  if (std::isnan(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", value);
  return text;
}

// "a,b,c": names as an option takes them (--scenes).
inline std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ",") + name;
  return text;
}

}  // namespace kinect3d
