#include "kinect3d/ball_refiner.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace kinect3d {

namespace {

// Gauss-Newton for the centre of a sphere of known radius; points farther than gate_m from the
// current surface are left out of each step.
Eigen::Vector3d fitSphere(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d center, double radius,
                          double gate_m) {
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    int used = 0;
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d offset = p - center;
      const double distance = offset.norm();
      const double residual = distance - radius;
      if (distance < 1e-9 || std::abs(residual) > gate_m) continue;
      const Eigen::Vector3d J = -offset / distance;  // d residual / d centre
      JtJ += J * J.transpose();
      Jtr += J * residual;
      ++used;
    }
    if (used < 4) break;
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    center += step;
    if (step.norm() < 1e-5) break;
  }
  return center;
}

}  // namespace

bool BallRefiner::gatherPoints(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                               const Eigen::Isometry3d& T_R_S, const PointProjector& surface) const {
  const Intrinsics& in = frame.intrinsics;
  // The candidate's voxels as a box in the robot frame, grown by a ball radius so that the parts
  // of the ball in voxels below the occupancy threshold are kept (the empty shell guarantees no
  // other occupied voxel that close), and that box's rectangle in the image.
  const float grow = static_cast<float>(grid.voxel_m() / 2 + config_.radius_m);
  const Eigen::Vector3f lo = grid.centerOf(candidate.min) - Eigen::Vector3f::Constant(grow);
  const Eigen::Vector3f hi = grid.centerOf(candidate.max) + Eigen::Vector3f::Constant(grow);
  const Eigen::Isometry3d T_S_R = T_R_S.inverse();
  double u0 = in.width, v0 = in.height, u1 = 0, v1 = 0;
  double depth_lo_m = 1e9, depth_hi_m = 0;  // the box's nearest and farthest depth along the optical axis
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d c_R((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                              (corner & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d c_S = T_S_R * c_R;
    if (c_S.z() < kMinDepthInFront_m) return false;  // reaches behind the sensor: not a ball in view
    const Eigen::Vector2d px = in.project(c_S);
    u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
    depth_lo_m = std::min(depth_lo_m, c_S.z()), depth_hi_m = std::max(depth_hi_m, c_S.z());
  }
  // A pixel's point, if it lies in the box and above the floor. The box in the sensor frame is a
  // parallelepiped, whose depths lie between its corners': a pixel beyond them (most of the
  // background round a ball) is refused by its depth, before its point is made (1 mm spare for the
  // box test's rounding).
  constexpr double kDepthSpare_m = 1e-3;
  depth_lo_m -= kDepthSpare_m, depth_hi_m += kDepthSpare_m;
  auto inBox = [&](int u, int v) -> std::optional<Eigen::Vector3d> {
    const double depth_m = frame.at(u, v) * 0.001;
    if (depth_m < depth_lo_m || depth_m > depth_hi_m) return std::nullopt;
    const Eigen::Vector3d p_R = T_R_S * in.backProject(u, v, depth_m);
    const Eigen::Vector3f p = p_R.cast<float>();
    if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) return std::nullopt;
    if (p_R.z() < surface.config().floor_margin_m) return std::nullopt;
    return p_R;
  };
  // The same for a pixel on a surface.
  auto pointAt = [&](int u, int v) -> std::optional<Eigen::Vector3d> {
    return surface.isSurface(frame, u, v) ? inBox(u, v) : std::nullopt;
  };
  // The rectangle holds the ball's pixels and, for a 0.81 m core near the sensor, a hundred times
  // more. A coarse pass finds where the points are, and refuses what is already wider than a ball.
  // Another Kinect facing ours throws specks of false depth about (a few pixels each, at any
  // depth): one inside the box, away from the ball in the image, is not the ball's. So the coarse
  // points are joined into pieces across the image, and a speck is left out: a piece of at most
  // kSpeckCells, farther than a ball's diameter from the largest piece's middle, whose depth no
  // neighbouring point shares. A piece of a real surface that only grazes the box (a leg below a
  // hand) goes on beyond it at its own depth and counts, and so does anything larger: a limb cut
  // into pieces by dropout stays as wide as it is.
  constexpr int kCoarse_px = 4;
  constexpr int kSpeckCells = 2;
  constexpr double kSameSurface_sigma = 3.0;
  const int ua = std::max(1, int(u0)), ub = std::min(in.width - 1, int(u1) + 1);
  const int va = std::max(1, int(v0)), vb = std::min(in.height - 1, int(v1) + 1);
  if (ub <= ua || vb <= va) return false;
  const int cells_u = (ub - ua + kCoarse_px - 1) / kCoarse_px, cells_v = (vb - va + kCoarse_px - 1) / kCoarse_px;
  constexpr int kEmpty = -1, kUnvisited = -2;
  coarse_.assign(static_cast<std::size_t>(cells_u) * cells_v, kEmpty);
  for (int cv = 0; cv < cells_v; ++cv) {
    for (int cu = 0; cu < cells_u; ++cu) {
      if (pointAt(ua + cu * kCoarse_px, va + cv * kCoarse_px)) coarse_[cv * cells_u + cu] = kUnvisited;
    }
  }
  // Pieces, 8-connected on the coarse grid: each cell gets its piece's index.
  piece_cells_.clear();
  for (int start = 0; start < static_cast<int>(coarse_.size()); ++start) {
    if (coarse_[start] != kUnvisited) continue;
    const int piece = static_cast<int>(piece_cells_.size());
    piece_cells_.push_back(0);
    flood_.assign(1, start);
    coarse_[start] = piece;
    while (!flood_.empty()) {
      const int cell = flood_.back();
      flood_.pop_back();
      ++piece_cells_[piece];
      const int cu = cell % cells_u, cv = cell / cells_u;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const int nu = cu + du, nv = cv + dv;
          if (nu < 0 || nv < 0 || nu >= cells_u || nv >= cells_v) continue;
          int& neighbour = coarse_[nv * cells_u + nu];
          if (neighbour != kUnvisited) continue;
          neighbour = piece;
          flood_.push_back(nv * cells_u + nu);
        }
      }
    }
  }
  if (piece_cells_.empty()) return false;
  const int largest =
      static_cast<int>(std::max_element(piece_cells_.begin(), piece_cells_.end()) - piece_cells_.begin());
  // The largest piece's middle and the ball's diameter there, in cells: a speck within it may be
  // the ball's own, cut off by a dark panel or a hole.
  Eigen::Vector2d middle = Eigen::Vector2d::Zero();
  double largest_nearest_m = 1e9;
  for (int cell = 0; cell < static_cast<int>(coarse_.size()); ++cell) {
    if (coarse_[cell] != largest) continue;
    const int cu = cell % cells_u, cv = cell / cells_u;
    middle += Eigen::Vector2d(cu, cv);
    largest_nearest_m = std::min(largest_nearest_m, frame.at(ua + cu * kCoarse_px, va + cv * kCoarse_px) * 0.001);
  }
  middle /= piece_cells_[largest];
  const double diameter_cells = 2.0 * config_.radius_m * in.fx / largest_nearest_m / kCoarse_px;
  speck_.assign(piece_cells_.size(), false);
  for (int piece = 0; piece < static_cast<int>(piece_cells_.size()); ++piece) {
    speck_[piece] = piece != largest && piece_cells_[piece] <= kSpeckCells;
  }
  for (int cell = 0; cell < static_cast<int>(coarse_.size()); ++cell) {
    const int piece = coarse_[cell];
    if (piece < 0 || !speck_[piece]) continue;
    const int cu = cell % cells_u, cv = cell / cells_u;
    if ((Eigen::Vector2d(cu, cv) - middle).norm() <= diameter_cells) speck_[piece] = false;
    const int u = ua + cu * kCoarse_px, v = va + cv * kCoarse_px;
    const double depth_m = frame.at(u, v) * 0.001;
    const double step_m = kSameSurface_sigma * noise_.axialSigma_m(depth_m) + noise_.quantisationStep_m(depth_m);
    for (int y = v - kCoarse_px; y <= v + kCoarse_px; y += kCoarse_px) {
      for (int x = u - kCoarse_px; x <= u + kCoarse_px; x += kCoarse_px) {
        if (x < 0 || y < 0 || x >= in.width || y >= in.height) continue;
        const bool in_piece = x >= ua && x < ub && y >= va && y < vb &&
                              coarse_[(y - va) / kCoarse_px * cells_u + (x - ua) / kCoarse_px] == piece;
        const double there_m = frame.at(x, y) * 0.001;
        if (!in_piece && there_m > 0.0 && std::abs(there_m - depth_m) <= step_m) speck_[piece] = false;
      }
    }
  }
  int cu0 = cells_u, cu1 = -1, cv0 = cells_v, cv1 = -1;
  double nearest_m = 1e9;
  for (int cv = 0; cv < cells_v; ++cv) {
    for (int cu = 0; cu < cells_u; ++cu) {
      const int piece = coarse_[cv * cells_u + cu];
      if (piece < 0 || speck_[piece]) continue;
      cu0 = std::min(cu0, cu), cu1 = std::max(cu1, cu), cv0 = std::min(cv0, cv), cv1 = std::max(cv1, cv);
      nearest_m = std::min(nearest_m, frame.at(ua + cu * kCoarse_px, va + cv * kCoarse_px) * 0.001);
    }
  }
  const double widest_px = config_.max_size_ratio * 2.0 * config_.radius_m * in.fx / nearest_m;
  if (kCoarse_px * std::max(cu1 - cu0, cv1 - cv0) > widest_px + 2 * kCoarse_px) return false;
  // Every surface pixel around the coarse points whose point lies in the box; and those in it beside
  // a dark panel's hole, counted for the ball's size only (the fits keep to surface pixels).
  points_.clear();
  pixels_.clear();
  beside_panels_ = 0;
  const int pu0 = ua + (cu0 - 1) * kCoarse_px, pu1 = ua + (cu1 + 1) * kCoarse_px;
  const int pv0 = va + (cv0 - 1) * kCoarse_px, pv1 = va + (cv1 + 1) * kCoarse_px;
  for (int v = std::max(va, pv0); v < std::min(vb, pv1 + 1); ++v) {
    for (int u = std::max(ua, pu0); u < std::min(ub, pu1 + 1); ++u) {
      if (const std::optional<Eigen::Vector3d> p_R = pointAt(u, v)) {
        points_.push_back(*p_R);
        pixels_.emplace_back(u, v);
      } else if (besidePanelHole(frame, u, v, surface) && inBox(u, v)) {
        ++beside_panels_;
      }
    }
  }
  return points_.size() >= kMinPoints;
}

bool BallRefiner::besidePanelHole(const DepthFrame& frame, int u, int v, const PointProjector& surface) const {
  // A classic ball's 12 black pentagons (about 7 cm across) return no depth. The surface test drops
  // the pixels round each hole (a neighbour without depth), which left a far ball with dark panels
  // a quarter of its pixels or less, too few for its size (lob_goalkeeper lost a fifth of its
  // frames). Such a pixel is the ball's when its hole is closed by the same surface, a radius deep at
  // most, within a panel's width ahead and to both sides: a panel's hole is. The hair over a head or
  // dark trousers over a shoe go on farther, and the gap between two feet is open above and below.
  constexpr double kPanelWidth_m = 0.08;
  const std::optional<Eigen::Vector2i> step = surface.holeBeside(frame, u, v);
  if (!step) return false;
  const double depth_m = frame.at(u, v) * 0.001;
  const int reach_px = static_cast<int>(std::ceil(kPanelWidth_m * frame.intrinsics.fx / depth_m));
  const Eigen::Vector2i hole(u + step->x(), v + step->y());
  auto closedToward = [&](const Eigen::Vector2i& direction) {
    for (int k = 1; k <= reach_px; ++k) {
      const Eigen::Vector2i at = hole + k * direction;
      if (at.x() < 0 || at.y() < 0 || at.x() >= frame.width() || at.y() >= frame.height()) return false;
      const std::uint16_t there_mm = frame.at(at.x(), at.y());
      if (there_mm != 0) return std::abs(there_mm * 0.001 - depth_m) <= config_.radius_m;
    }
    return false;
  };
  const Eigen::Vector2i across(step->y(), step->x());
  return closedToward(*step) && closedToward(across) && closedToward(-across);
}

bool BallRefiner::isBallSized(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray, double range,
                              double focal_px) const {
  // Enough pixels for a ball at this range (those round its dark panels too), and not wider than one.
  const double r = config_.radius_m;
  const double ball_pixels = M_PI * std::pow(focal_px * r / range, 2);
  if (points_.size() + beside_panels_ < config_.min_visible_fraction * ball_pixels) return false;
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  double side_lo = 1e9, side_hi = -1e9, up_lo = 1e9, up_hi = -1e9;
  for (const Eigen::Vector3d& p : points_) {
    const double s = side.dot(p - centroid), h = up.dot(p - centroid);
    side_lo = std::min(side_lo, s), side_hi = std::max(side_hi, s);
    up_lo = std::min(up_lo, h), up_hi = std::max(up_hi, h);
  }
  const double widest = std::max(side_hi - side_lo, up_hi - up_lo);
  return widest <= config_.max_size_ratio * 2.0 * r;
}

Eigen::Vector3d BallRefiner::centreFromDisc(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray,
                                            double floor_margin_m) const {
  // Pixels sample the cap evenly in the image, so for a disc of normalised radius a (the edge
  // filter trims the limb, a < 1) the mean depth lies (2/3)(1 - (1 - a^2)^(3/2)) / a^2 of a radius
  // in front of the centre. a is measured from the spread of the points across the ray (the 98th
  // percentile of the distance from the centroid, scaled to the whole disc).
  constexpr double kSpreadQuantile = 0.98;
  constexpr double kMinDisc = 0.3;  // below this the cap is too small to measure its spread
  const double r = config_.radius_m;
  radial_.clear();
  for (const Eigen::Vector3d& p : points_) {
    const Eigen::Vector3d across_ray = (p - centroid) - ray.dot(p - centroid) * ray;
    radial_.push_back(across_ray.norm());
  }
  const std::size_t rank = static_cast<std::size_t>(radial_.size() * kSpreadQuantile);
  std::nth_element(radial_.begin(), radial_.begin() + rank, radial_.end());
  const double a = std::clamp(radial_[rank] / std::sqrt(kSpreadQuantile) / r, kMinDisc, 1.0);
  const double cap_depth = (2.0 / 3.0) * (1.0 - std::pow(1.0 - a * a, 1.5)) / (a * a);
  const Eigen::Vector3d from_centroid = centroid + cap_depth * r * ray;
  // A ball on or just over the floor lost its lowest points to the floor band: the centroid of what
  // is left lies above the cap's, by up to 1 cm for a resting ball beyond 3 m. The shift, for a ball
  // where the cap puts it, is the mean of the cap sampled evenly across the view less the mean of
  // its samples above the band. Taken once: iterated to its fixed point (the cut moves with the
  // centre) it feeds the far ball's noise back, and a resting ball 6 m away came out up to 1 cm low.
  constexpr int kSamples = 24;  // across the disc, each way
  if (from_centroid.z() - r >= floor_margin_m) return from_centroid;
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  Eigen::Vector3d all = Eigen::Vector3d::Zero(), above = Eigen::Vector3d::Zero();
  int all_n = 0, above_n = 0;
  for (int i = 0; i < kSamples; ++i) {
    for (int j = 0; j < kSamples; ++j) {
      const double s = a * (2.0 * (i + 0.5) / kSamples - 1.0), h = a * (2.0 * (j + 0.5) / kSamples - 1.0);
      if (s * s + h * h > a * a) continue;
      const Eigen::Vector3d offset = r * (s * side + h * up - std::sqrt(1.0 - s * s - h * h) * ray);
      all += offset, ++all_n;
      if (from_centroid.z() + offset.z() >= floor_margin_m) above += offset, ++above_n;
    }
  }
  if (above_n == 0) return from_centroid;  // no such ball would show a point above the band
  return from_centroid - (above / above_n - all / all_n);
}

std::optional<Eigen::Vector3d> BallRefiner::centreFromOutline(const Eigen::Vector3d& center_R, const DepthFrame& frame,
                                                              const SensorCoverage& coverage,
                                                              const Eigen::Isometry3d& T_R_S,
                                                              double floor_margin_m) const {
  constexpr int kLook_px = 4;              // past an end of the ball's pixels, looking for what bounds it
  constexpr double kMinHiddenShare = 0.2;  // of the outline's ends: below this the ball is whole
  constexpr int kMinLimbEnds = 6;
  // A ball's outline is a circle of its radius at its range; an arm's, a hand's or a strip of wall's
  // is not. Measured on the simulated balls of the detection and trajectory reports (every noise
  // effect on) against the phantoms articulated people gave before this check:
  //  - whole: the circle fitted to the limb moves at most 0.12 radii from the centre the cap gave,
  //    80 % of the limb rays lie within 0.36 radii of it (a smeared ball's sides lie inside), no
  //    pixel beyond 1.2 radii. Forearms with hands move it 0.65 radii or spread 0.3-0.65.
  //  - seen in part: the limb rays' median distance from the circle stays under 0.12 radii and no
  //    pixel lies beyond 1.24 radii (1.13 beyond 3 m). In the real five_people frame a wall's edge
  //    between two people fails both (0.20, 1.70), a strip of wall beside the view's edge the second
  //    (1.35).
  constexpr double kMaxWholeMove = 0.3;         // radii
  constexpr double kMaxWholeResidualP80 = 0.4;  // radii, the 80th percentile over the limb rays
  constexpr double kMaxLimbResidual = 0.15;     // radii, the median over the limb rays of a ball seen in part
  constexpr double kMaxPixelSpread = 1.3;       // radii across the view from the fitted centre
  constexpr double kMaxPartMove = 0.8;          // radii
  constexpr double kMaxNotchedResidualP80 = 0.25;
  constexpr double kMaxNotchedElongation = 1.8;  // the pixels' spread, longest over shortest
  constexpr double kNotch_r = 0.15;              // an end this far inside the circle may be a panel's notch
  constexpr int kSectors = 8, kMinSectors = 7;   // round the centre, holding limb ends
  const Intrinsics& in = frame.intrinsics;
  const Eigen::Isometry3d T_S_R = T_R_S.inverse();
  double front_m = 1e9;  // the ball's nearest depth along the optical axis
  for (const Eigen::Vector3d& p : points_) front_m = std::min(front_m, (T_S_R * p).z());
  const double ball_far_m = (T_S_R * center_R).z() + config_.radius_m;
  const double occluder_below_m = front_m - std::max(0.03, 3.0 * noise_.axialSigma_m(front_m));

  // The ends of the ball's pixels along each row and column. An end is the ball's limb when beyond
  // it the view passes the ball (no depth, or depth behind the ball); it is hidden when something
  // nearer or the edge of the sensor's view bounds it. An end where the floor band cut the ball's
  // points off (what lies beyond is at the ball's depth, below floor_margin_m) is neither: the ball
  // goes on there, as a resting ball's lowest few centimetres do, but its outline is not seen.
  Eigen::Vector2i lo = pixels_.front(), hi = pixels_.front();
  for (const Eigen::Vector2i& px : pixels_) lo = lo.cwiseMin(px), hi = hi.cwiseMax(px);
  constexpr int kNone = -1;
  row_ends_.assign(hi.y() - lo.y() + 1, {kNone, kNone});     // per row from lo.y(): (min u, max u)
  column_ends_.assign(hi.x() - lo.x() + 1, {kNone, kNone});  // per column from lo.x(): (min v, max v)
  auto extend = [](std::pair<int, int>& ends, int at) {
    ends = ends.first == kNone ? std::pair{at, at} : std::pair{std::min(ends.first, at), std::max(ends.second, at)};
  };
  for (const Eigen::Vector2i& px : pixels_) {
    extend(row_ends_[px.y() - lo.y()], px.x());
    extend(column_ends_[px.x() - lo.x()], px.y());
  }
  limb_rays_S_.clear();       // unit rays through the outer edge of limb pixels
  limb_blank_.clear();        // and whether beyond each the sensor returned nothing at all
  floor_cut_rays_S_.clear();  // and through what lies beyond the ends the floor band cut
  int hidden = 0;
  auto visit = [&](int u, int v, int du, int dv) {
    bool passes_behind = false;
    for (int k = 1; k <= kLook_px; ++k) {
      const int x = u + k * du, y = v + k * dv;
      if (!coverage.inView(x, y)) {
        ++hidden;  // cut by the edge of the view
        return;
      }
      const double d_m = frame.at(x, y) * 0.001;
      if (d_m > 0.0 && d_m < occluder_below_m) {
        ++hidden;  // something nearer
        return;
      }
      if (d_m > 0.0 && d_m <= ball_far_m) {
        if ((T_R_S * in.backProject(x, y, d_m)).z() < floor_margin_m) {
          floor_cut_rays_S_.push_back(Eigen::Vector3d((x - in.cx) / in.fx, (y - in.cy) / in.fy, 1.0).normalized());
          return;
        }
        continue;  // the ball's own edge pixels, dropped by the edge filter
      }
      passes_behind = passes_behind || d_m > 0.0;
    }
    limb_rays_S_.push_back(
        Eigen::Vector3d((u + 0.5 * du - in.cx) / in.fx, (v + 0.5 * dv - in.cy) / in.fy, 1.0).normalized());
    limb_blank_.push_back(!passes_behind);
  };
  for (int row = 0; row < static_cast<int>(row_ends_.size()); ++row) {
    if (row_ends_[row].first == kNone) continue;
    visit(row_ends_[row].first, lo.y() + row, -1, 0);
    visit(row_ends_[row].second, lo.y() + row, 1, 0);
  }
  for (int column = 0; column < static_cast<int>(column_ends_.size()); ++column) {
    if (column_ends_[column].first == kNone) continue;
    visit(lo.x() + column, column_ends_[column].first, 0, -1);
    visit(lo.x() + column, column_ends_[column].second, 0, 1);
  }
  const int ends = hidden + static_cast<int>(limb_rays_S_.size());
  const bool whole = hidden < kMinHiddenShare * ends;
  if (static_cast<int>(limb_rays_S_.size()) < kMinLimbEnds) {
    // Too small an outline to fit: a whole one is a few pixels the size check judged; a part-seen
    // one shows nothing that proves it round.
    return whole ? std::optional<Eigen::Vector3d>(center_R) : std::nullopt;
  }

  // Gauss-Newton across the view (the depth stays the cap's): every limb ray passes one radius from
  // the centre, less the pixel the edge filter trims off the limb.
  const Eigen::Vector3d c0_S = T_S_R * center_R;
  const double range = c0_S.norm();
  const double r_eff = config_.radius_m - range / in.fx;
  const Eigen::Vector3d ray = c0_S / range;
  const Eigen::Vector3d e1 = ray.cross(Eigen::Vector3d::UnitY()).normalized(), e2 = ray.cross(e1);
  // The centre across the view fitted to the limb rays not left out.
  auto fitOutline = [&](Eigen::Vector2d ab) {
    for (int iteration = 0; iteration < 10; ++iteration) {
      const Eigen::Vector3d c = c0_S + ab.x() * e1 + ab.y() * e2;
      Eigen::Matrix2d JtJ = Eigen::Matrix2d::Zero();
      Eigen::Vector2d Jtr = Eigen::Vector2d::Zero();
      for (std::size_t i = 0; i < limb_rays_S_.size(); ++i) {
        if (notch_[i]) continue;
        const Eigen::Vector3d& d = limb_rays_S_[i];
        const Eigen::Vector3d w = c - c.dot(d) * d;  // from the ray to the centre, across the ray
        const double distance = w.norm();
        if (distance < 1e-9) continue;
        const Eigen::Vector2d J(w.dot(e1) / distance, w.dot(e2) / distance);
        JtJ += J * J.transpose();
        Jtr += J * (distance - r_eff);
      }
      const Eigen::Vector2d step = JtJ.ldlt().solve(-Jtr);
      ab += step;
      if (step.norm() < 1e-5) break;
    }
    return ab;
  };
  notch_.assign(limb_rays_S_.size(), false);
  Eigen::Vector2d ab = fitOutline(Eigen::Vector2d::Zero());
  auto fromCentreOf_r = [&](const Eigen::Vector2d& at, const Eigen::Vector3d& d) {
    const Eigen::Vector3d c = c0_S + at.x() * e1 + at.y() * e2;
    return (c - c.dot(d) * d).norm() / config_.radius_m;
  };
  auto residualAt = [&](const Eigen::Vector2d& at, double share) {
    radial_.clear();
    for (std::size_t i = 0; i < limb_rays_S_.size(); ++i) {
      if (!notch_[i]) radial_.push_back(std::abs(fromCentreOf_r(at, limb_rays_S_[i]) - r_eff / config_.radius_m));
    }
    const auto rank = radial_.begin() + static_cast<std::ptrdiff_t>(share * (radial_.size() - 1));
    std::nth_element(radial_.begin(), rank, radial_.end());
    return *rank;
  };
  // A classic ball's black panels return no depth: where one crosses the limb the outline has a
  // notch, its ends inside the circle with nothing at all beyond them. A whole outline that fails
  // as a circle is fitted again without such ends; it must then still be a ball's all round.
  bool notched = false;
  if (whole && (ab.norm() > kMaxWholeMove * config_.radius_m || residualAt(ab, 0.8) > kMaxWholeResidualP80)) {
    Eigen::Vector2d at = ab;
    for (int round = 0; round < 4; ++round) {
      for (std::size_t i = 0; i < limb_rays_S_.size(); ++i) {
        notch_[i] = limb_blank_[i] && fromCentreOf_r(at, limb_rays_S_[i]) < r_eff / config_.radius_m - kNotch_r;
      }
      at = fitOutline(at);
    }
    // The sectors round the centre holding limb ends; where the floor band cut the ball off, no
    // limb can be seen, and the sector counts as seen.
    int sectors = 0, kept = 0;
    std::array<bool, kSectors> seen{};
    const Eigen::Vector3d c = c0_S + at.x() * e1 + at.y() * e2;
    auto see = [&](const Eigen::Vector3d& d) {
      const Eigen::Vector3d w = d * c.dot(d) - c;  // centre to the ray
      const double angle = std::atan2(w.dot(e2), w.dot(e1));
      seen[static_cast<std::size_t>(std::clamp(int((angle + M_PI) / (2 * M_PI) * kSectors), 0, kSectors - 1))] = true;
    };
    for (std::size_t i = 0; i < limb_rays_S_.size(); ++i) {
      if (notch_[i]) continue;
      ++kept;
      see(limb_rays_S_[i]);
    }
    for (const Eigen::Vector3d& d : floor_cut_rays_S_) see(d);
    for (bool s : seen) sectors += s;
    // Panels are spread over the ball: what they leave is about as wide one way as the other. A
    // foot or a hand whose long sides were taken for notches is not.
    Eigen::Vector2d mean_px = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2i& px : pixels_) mean_px += px.cast<double>();
    mean_px /= static_cast<double>(pixels_.size());
    Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
    for (const Eigen::Vector2i& px : pixels_) {
      const Eigen::Vector2d d = px.cast<double>() - mean_px;
      spread += d * d.transpose();
    }
    const double longest = fw::largestEigenvalue(spread);
    const double shortest = spread.trace() - longest;
    const bool round = std::sqrt(longest / std::max(shortest, 1e-9)) <= kMaxNotchedElongation;
    if (kept >= kMinLimbEnds && sectors >= kMinSectors && round && at.norm() <= kMaxWholeMove * config_.radius_m &&
        residualAt(at, 0.8) <= kMaxNotchedResidualP80) {
      ab = at;
      notched = true;
    } else {
      notch_.assign(limb_rays_S_.size(), false);
    }
  }
  // The centroid of the smallest part of a disc the refiner accepts (min_visible_fraction, a
  // quarter) lies 0.65 radii from the centre (a half disc's 0.42): a larger move is not a ball's.
  if (ab.norm() > (whole ? kMaxWholeMove : kMaxPartMove) * config_.radius_m) return std::nullopt;
  const Eigen::Vector3d c_S = c0_S + ab.x() * e1 + ab.y() * e2;
  auto fromCentre_r = [&](const Eigen::Vector3d& d) { return (c_S - c_S.dot(d) * d).norm() / config_.radius_m; };
  for (const Eigen::Vector3d& p : points_) {
    if (fromCentre_r((T_S_R * p).normalized()) > kMaxPixelSpread) return std::nullopt;
  }
  // At least half the ball lies in the sensor's view: a centre beyond its edge (the image border or
  // a band that never returns depth) is a guess at what is not seen. A hand cut by the border fits
  // one as well as a ball does; so does the wall strip beside five_people's dead band.
  const Eigen::Vector2d centre_px = in.project(c_S);
  if (!coverage.inView(static_cast<int>(std::lround(centre_px.x())), static_cast<int>(std::lround(centre_px.y())))) {
    return std::nullopt;
  }
  if (residualAt(ab, whole ? 0.8 : 0.5) > (whole ? kMaxWholeResidualP80 : kMaxLimbResidual)) return std::nullopt;
  // A whole ball keeps the cap's centre; a part-seen one takes the outline's.
  return whole && !notched ? center_R : T_R_S * c_S;
}

bool BallRefiner::surfacedLikeABall(const Eigen::Vector3d& center_R, const Eigen::Isometry3d& T_R_S) const {
  // A sphere's visible surface recedes by r(1 - sqrt(1 - rho^2)) from its nearest point to a point
  // rho radii off-centre across the view: r at the limb. Fitted by least squares with an offset and
  // a tilt across the view (a flat surface turned away recedes linearly), the curvature of a ball is
  // r; of a flag, a wall or a torso 0; of a hand or a foot well under r. Measured on every simulated
  // ball the detector found in the built-in scenes and the people scenes (8,000, every noise effect,
  // dark panels and another Kinect included): the fit stays above 0.8 r less 3 standard errors for
  // all of them (a ball under 1 m reads 0.89 r, the limb trimmed); flags and limbs that passed every
  // other check read 0.1-0.5 r with a tenth of a radius of error.
  constexpr double kMinCurvature = 0.8;  // radii
  constexpr double kMaxBelow_sigma = 3.0;
  constexpr double kMaxRho = 0.95;  // the limb's slope is infinite: stop short of it
  constexpr double kIndependentPoints = 100.0;
  // And a ball is one smooth surface: its points lie on the fit within the sensor's noise. An arm
  // before a body, or a hand before a head, is two surfaces a step apart, and the fit between them
  // leaves a share of points far off it. Beyond 4 sigma of the noise model lie at most 3 % of a
  // ball's points (every noise effect, false depth from another Kinect inside the disc included,
  // and on units up to 1.6 times noisier than the model; a ball smeared at its kick, close by, a
  // little more) and 4-30 % of such pairs'.
  constexpr double kFarOff_sigma = 4.0;
  constexpr double kMaxFarOffShare = 0.04;
  const Eigen::Isometry3d T_S_R = T_R_S.inverse();
  const Eigen::Vector3d c_S = T_S_R * center_R;
  const double range = c_S.norm(), r = config_.radius_m;
  const Eigen::Vector3d ray = c_S / range;
  const Eigen::Vector3d e1 = ray.cross(Eigen::Vector3d::UnitY()).normalized(), e2 = ray.cross(e1);
  auto regressors = [&](const Eigen::Vector3d& p_S) {
    const Eigen::Vector3d d = p_S.normalized();
    const Eigen::Vector2d across((d - ray).dot(e1) * range / r, (d - ray).dot(e2) * range / r);
    const double rho = std::min(across.norm(), kMaxRho);
    return Eigen::Vector4d(1.0, 1.0 - std::sqrt(1.0 - rho * rho), across.x(), across.y());
  };
  // Each point's regressors and range, kept for the residuals below.
  Eigen::Matrix4d JtJ = Eigen::Matrix4d::Zero();
  Eigen::Vector4d Jtz = Eigen::Vector4d::Zero();
  regressed_.clear();
  for (const Eigen::Vector3d& p : points_) {
    const Eigen::Vector3d p_S = T_S_R * p;
    const Regressed& point = regressed_.emplace_back(Regressed{regressors(p_S), p_S.norm()});
    JtJ += point.J * point.J.transpose();
    Jtz += point.J * point.range_m;
  }
  const Eigen::Vector4d fit = JtJ.ldlt().solve(Jtz);
  // A point's expected distance from the surface: the depth noise, and where the surface slopes
  // away towards the limb, the lateral noise times that slope (a sphere's: rho / sqrt(1 - rho^2)).
  // Nguyen's sigma already holds the rounding to depth steps; adding the step's own spread again is
  // a margin where, far out, a step is most of the spread.
  const double axial_m = std::hypot(noise_.axialSigma_m(range), noise_.quantisationStep_m(range) / std::sqrt(12.0));
  const double lateral_m = noise_.lateralSigma_m(range);
  double squares = 0.0;
  int far_off = 0;
  for (const Regressed& point : regressed_) {
    const double residual = point.range_m - point.J.dot(fit);
    squares += residual * residual;
    const double cosine = 1.0 - point.J[1];  // sqrt(1 - rho^2), at most rho = kMaxRho
    const double sigma_m = std::hypot(axial_m, lateral_m * std::sqrt(1.0 - cosine * cosine) / cosine);
    far_off += std::abs(residual) > kFarOff_sigma * sigma_m;
  }
  // The residuals' variance, and neighbouring pixels sharing their correlation window.
  const double n = static_cast<double>(points_.size());
  const double variance = squares / std::max(1.0, n - 4.0) * std::max(1.0, n / kIndependentPoints);
  const double standard_error = std::sqrt(variance * JtJ.inverse()(1, 1));
  return fit[1] >= kMinCurvature * r - kMaxBelow_sigma * standard_error && far_off <= kMaxFarOffShare * n;
}

Eigen::Matrix3d BallRefiner::covariance(const Eigen::Vector3d& ray, double range, int points) const {
  // A random part, the per-point noise over the number of points (at most kMaxIndependentPoints:
  // neighbouring Kinect pixels share their correlation window), and a systematic part, 1 cm in
  // every direction for the extrinsics plus a quarter of the depth quantisation step along the
  // ray, which grows with the square of the range.
  constexpr double kMaxIndependentPoints = 100.0;
  constexpr double kExtrinsicsSigma_m = 0.01;
  const double n_eff = std::clamp(double(points), 1.0, kMaxIndependentPoints);
  const double extrinsics = kExtrinsicsSigma_m * kExtrinsicsSigma_m;
  const double along = std::sqrt(std::pow(noise_.axialSigma_m(range), 2) / n_eff +
                                 std::pow(noise_.quantisationStep_m(range) / 4, 2) + extrinsics);
  const double across = std::sqrt(std::pow(noise_.lateralSigma_m(range), 2) / n_eff + extrinsics);
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  Eigen::Matrix3d basis;
  basis << side, up, ray;
  return basis * Eigen::Vector3d(across * across, across * across, along * along).asDiagonal() * basis.transpose();
}

std::optional<BallFit> BallRefiner::refine(const BallCandidate& candidate, const OccupancyGrid& grid,
                                           const DepthFrame& frame, const SensorCoverage& coverage,
                                           const Eigen::Isometry3d& T_R_S, const PointProjector& surface) const {
  if (!gatherPoints(candidate, grid, frame, T_R_S, surface)) return std::nullopt;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points_) centroid += p;
  centroid /= double(points_.size());
  const Eigen::Vector3d sensor_R = T_R_S.translation();
  const Eigen::Vector3d ray = (centroid - sensor_R).normalized();
  const double range = (centroid - sensor_R).norm();
  if (!isBallSized(centroid, ray, range, frame.intrinsics.fx)) return std::nullopt;

  BallFit fit;
  fit.center_R = centreFromDisc(centroid, ray, surface.config().floor_margin_m);
  // Where the cap's depth is resolved (noise well under the radius) a sphere of the known radius
  // fitted to its points also uses the cap's shape, which keeps a partly hidden ball centred.
  // Depth noise moves points off the sphere mostly along the ray, so on average they lie
  // sqrt(r^2 + sigma^2) from the centre: that is the radius fitted. A fit that strays from the
  // disc estimate by more than a third of a radius is not trusted.
  const double r = config_.radius_m;
  const double sigma = noise_.axialSigma_m(range);
  if (sigma + noise_.quantisationStep_m(range) / 2 < r / 4) {
    const double gate = std::max(0.5 * r, 3.0 * (sigma + noise_.quantisationStep_m(range)));
    const Eigen::Vector3d sphere = fitSphere(points_, fit.center_R, std::hypot(r, sigma), gate);
    if ((sphere - fit.center_R).norm() < r / 3) fit.center_R = sphere;
  }
  const std::optional<Eigen::Vector3d> outlined =
      centreFromOutline(fit.center_R, frame, coverage, T_R_S, surface.config().floor_margin_m);
  if (!outlined) return std::nullopt;
  fit.center_R = *outlined;
  if (!surfacedLikeABall(fit.center_R, T_R_S)) return std::nullopt;
  // A ball cannot sink into the floor: its centre stays near one radius up.
  if (fit.center_R.z() < 0.5 * r) return std::nullopt;
  fit.points = static_cast<int>(points_.size());
  fit.state = fit.center_R.z() > r + config_.air_min_height_m ? fw::BallState::kAir : fw::BallState::kGround;
  fit.covariance_m2 = covariance(ray, range, fit.points);
  return fit;
}

}  // namespace kinect3d
