// The 3D line map in the map frame: every observation of a physical edge (a Line3d from one RGB-D frame) is merged
// into one map line, which is refitted and kept with its support (number of observations) and extent.
//
// An observation joins the map line it is closest to among those it is compatible with: directions within
// max_angle_deg, both end points within max_distance_m (+ max_distance_per_m times the observation's range) of the
// map line, and the extents overlapping or apart by at most max_gap_m along it. Otherwise it starts a new map line.
// After a merge the grown line is fused with any other map line that has become compatible with it.
//
// Refit: each map line keeps the weighted first and second moments of its observations (each a uniform
// distribution along its segment, weight inliers / max(rms, min_rms_m)^2), so the refitted line is their total
// least squares (PCA). Extent: the two extreme end points along the refitted direction. Memory per map line is
// constant, so the map grows with the number of distinct edges, not with the number of frames.
#ifndef INSITU_CALIBRATION_LINES_LINE_MAP_H
#define INSITU_CALIBRATION_LINES_LINE_MAP_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/lines/line3d_fitter.h"

namespace insitu_calibration
{
struct LineMapOptions
{
  double max_angle_deg = 3.0;
  double max_distance_m = 0.03;
  double max_distance_per_m = 0.005;  // added per metre of the observation's range (depth noise grows with it)
  double max_gap_m = 0.15;
  double min_rms_m = 0.002;  // floor of an observation's rms in its weight
};

struct MapLine
{
  Eigen::Vector3d point = Eigen::Vector3d::Zero();       // weighted centroid
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit
  double s_min = 0.0;                                    // extent along direction from point
  double s_max = 0.0;
  int support = 0;      // observations merged
  double weight = 0.0;  // sum of the observations' weights
  double first_stamp = 0.0;
  double last_stamp = 0.0;

  Eigen::Vector3d a() const { return point + s_min * direction; }
  Eigen::Vector3d b() const { return point + s_max * direction; }
  double length() const { return s_max - s_min; }
  // n >= 2 points evenly spaced from a() to b() (for LineCorrespondence::world).
  std::vector<Eigen::Vector3d> samplePoints(int n) const;
  // How far the observations lie from the fitted line: the RMS perpendicular distance (weighted, m). A few mm for a
  // clean edge; much more when the map line mixes nearby parallel edges (stripes, a frame's two sides).
  double spread() const;

  // Sufficient statistics (constant size), about reference (the first observation's midpoint, for precision).
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_wx = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_wxx = Eigen::Matrix3d::Zero();
  Eigen::Vector3d extreme_lo = Eigen::Vector3d::Zero();  // end points of the extent
  Eigen::Vector3d extreme_hi = Eigen::Vector3d::Zero();
};

class LineMap
{
public:
  explicit LineMap(const LineMapOptions& options = LineMapOptions());

  // Merges one observation (map frame). Returns the index of the map line that holds it afterwards, or -1 when the
  // observation is not finite or has zero length (ignored).
  int insert(const Line3d& observation);
  void insert(const std::vector<Line3d>& observations);

  const std::vector<MapLine>& lines() const { return lines_; }
  // The map lines seen at least min_support times.
  std::vector<MapLine> lines(int min_support) const;
  size_t size() const { return lines_.size(); }
  void clear() { lines_.clear(); }
  const LineMapOptions& options() const { return options_; }

private:
  bool compatible(const MapLine& line, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double range_m,
                  double* distance) const;
  int fuseWithOthers(int index);

  LineMapOptions options_;
  std::vector<MapLine> lines_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_LINE_MAP_H
