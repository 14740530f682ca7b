#include "insitu_calibration/map/surface_voxels.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
namespace
{
double depthAt(const cv::Mat& depth, int row, int col)
{
  if (depth.type() == CV_16UC1)
    return 0.001 * depth.at<uint16_t>(row, col);
  if (depth.type() == CV_32FC1)
    return depth.at<float>(row, col);
  return 0.0;
}

// The cell of a cubic grid of the given size holding the point; 21 bits per axis: +-52 km at 5 cm (points beyond
// wrap: harmless, a building is far smaller).
uint64_t cellKey(const Eigen::Vector3d& point, double size)
{
  const auto cell = [&](double v) {
    return static_cast<uint64_t>(static_cast<int64_t>(std::floor(v / size)) & 0x1FFFFF);
  };
  return cell(point.x()) | (cell(point.y()) << 21) | (cell(point.z()) << 42);
}
}  // namespace

SurfaceVoxels::SurfaceVoxels(const SurfaceVoxelOptions& options) : options_(options)
{
  options_.voxel_m = std::max(options_.voxel_m, 1e-3);
  options_.pixel_step = std::max(options_.pixel_step, 1);
  options_.sample_step_m = std::max(options_.sample_step_m, 1e-3);
}

uint64_t SurfaceVoxels::key(const Eigen::Vector3d& point) const
{
  return cellKey(point, options_.voxel_m);
}

void SurfaceVoxels::insert(const Eigen::Vector3d& point)
{
  if (point.allFinite())
    voxels_.insert(key(point));
}

bool SurfaceVoxels::occupied(const Eigen::Vector3d& point) const
{
  return point.allFinite() && voxels_.count(key(point)) > 0;
}

void SurfaceVoxels::insertDepth(const RgbdFrame& frame)
{
  insertSamples(frame.T_map_camera, depthSamples(frame));
}

std::vector<Eigen::Vector3f> SurfaceVoxels::depthSamples(const RgbdFrame& frame, double cell_m) const
{
  const cv::Mat& depth = frame.depth;
  std::vector<Eigen::Vector3f> out;
  std::unordered_set<uint64_t> cells;
  for (int row = options_.pixel_step / 2; row < depth.rows; row += options_.pixel_step)
    for (int col = options_.pixel_step / 2; col < depth.cols; col += options_.pixel_step)
    {
      const double z = depthAt(depth, row, col);
      if (!(z > 0.0 && z <= options_.max_range_m))
        continue;
      const Eigen::Vector2d ray = frame.camera.normalize(Eigen::Vector2d(col, row));
      const Eigen::Vector3d point(z * ray.x(), z * ray.y(), z);
      if (cell_m > 0.0 && !cells.insert(cellKey(point, cell_m)).second)
        continue;
      out.push_back(point.cast<float>());
    }
  return out;
}

void SurfaceVoxels::insertSamples(const Eigen::Isometry3d& T_map_camera, const std::vector<Eigen::Vector3f>& samples)
{
  for (const Eigen::Vector3f& sample : samples)
  {
    const Eigen::Vector3d local = sample.cast<double>();
    const Eigen::Vector3d point = T_map_camera * local;
    // A layer 1.5 voxels deep behind the surface: a sight line crossing it meets two voxels at any angle.
    const Eigen::Vector3d behind = 0.5 * options_.voxel_m * (T_map_camera.linear() * local.normalized());
    for (int k = 0; k < 4; ++k)
      insert(point + k * behind);
  }
}

bool SurfaceVoxels::blocks(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const
{
  return blocks(from, to, Eigen::Vector3d::Zero());
}

bool SurfaceVoxels::blocks(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                           const Eigen::Vector3d& line_direction) const
{
  const Eigen::Vector3d d = to - from;
  const double range = d.norm();
  const double end = range - options_.target_margin_m - options_.target_margin_per_m * range;
  const bool other_surfaces = options_.other_surface_margin_m > 0.0 && line_direction.norm() > 0.5;
  const double last_s = other_surfaces ? std::max(end, range - options_.other_surface_margin_m) : end;
  if (!(last_s > options_.near_margin_m))
    return false;
  const Eigen::Vector3d unit = d / range;
  const double step = 0.5 * options_.voxel_m;
  int hits = 0;
  uint64_t last = ~uint64_t{0};
  for (double s = options_.near_margin_m; s < last_s; s += step)
  {
    const Eigen::Vector3d point = from + s * unit;
    const uint64_t k = key(point);
    if (k == last)
      continue;
    last = k;
    if (voxels_.count(k) == 0)
      continue;
    // Within the target's margin only a surface other than the target's own hides it.
    if (s >= end && onSurfaceThrough(point, to, line_direction.normalized()))
      continue;
    if (++hits >= options_.min_hits)
      return true;
  }
  return false;
}

bool SurfaceVoxels::onSurfaceThrough(const Eigen::Vector3d& point, const Eigen::Vector3d& target,
                                     const Eigen::Vector3d& direction) const
{
  Eigen::Vector3d across = target - point;
  across -= across.dot(direction) * direction;
  const double distance = across.norm();
  const double v = options_.voxel_m;
  if (distance < 1.5 * v)  // beside the line: its own edge
    return true;
  across /= distance;
  int free_run = 0;
  for (double t = v; t < distance - v; t += v)
  {
    free_run = occupied(point + t * across) ? 0 : free_run + 1;
    if (free_run >= 2)  // an empty stretch (an object's inside); one empty voxel is a hole where depth was sparse
      return false;
  }
  return true;
}

std::vector<Segment3d> SurfaceVoxels::unoccludedParts(const Eigen::Vector3d& center,
                                                      const std::vector<Segment3d>& lines) const
{
  std::vector<Segment3d> out;
  for (const Segment3d& line : lines)
  {
    const int n = std::clamp(static_cast<int>(std::ceil(line.length() / options_.sample_step_m)), 1, 100);
    int run_start = -1;  // first visible sample of the current run
    for (int k = 0; k <= n; ++k)
    {
      const bool visible = k < n && !blocks(center, line.pointAt((k + 0.5) / n), line.b - line.a);
      if (visible && run_start < 0)
        run_start = k;
      if (!visible && run_start >= 0)
      {
        out.push_back({line.pointAt(static_cast<double>(run_start) / n), line.pointAt(static_cast<double>(k) / n)});
        run_start = -1;
      }
    }
  }
  return out;
}

bool SurfaceVoxels::hiddenFromAll(const std::vector<Eigen::Vector3d>& viewpoints, const Segment3d& line) const
{
  const int n = std::clamp(static_cast<int>(std::ceil(line.length() / (2.5 * options_.sample_step_m))), 1, 40);
  for (int k = 0; k < n; ++k)
    for (const Eigen::Vector3d& from : viewpoints)
      if (!blocks(from, line.pointAt((k + 0.5) / n), line.b - line.a))
        return false;
  return true;
}

long DepthRangeGrid::cellOf(const Eigen::Vector2d& normalised) const
{
  if (!(cell > 0.0))
    return -1;
  const Eigen::Vector2d at = (normalised - origin) / cell;
  if (!(at.x() >= 0.0 && at.y() >= 0.0 && at.x() < cols && at.y() < rows))
    return -1;
  return static_cast<long>(at.y()) * cols + static_cast<long>(at.x());
}

double DepthRangeGrid::nearestAt(const Eigen::Vector2d& normalised) const
{
  const long k = cellOf(normalised);
  return k < 0 || static_cast<size_t>(k) >= nearest_m.size() ? 0.0 : nearest_m[k];
}

double DepthRangeGrid::farthestAt(const Eigen::Vector2d& normalised) const
{
  const long k = cellOf(normalised);
  return k < 0 || static_cast<size_t>(k) >= farthest_m.size() ? 0.0 : farthest_m[k];
}

DepthRangeGrid depthRangeGrid(const RgbdFrame& frame, double cell_px, int pixel_step)
{
  DepthRangeGrid grid;
  const Intrinsics& k = frame.camera.intrinsics;
  grid.cell = cell_px / k.fx;
  // A cell of margin on every side: distortion moves the image's border a little.
  grid.origin = Eigen::Vector2d(-k.cx / k.fx, -k.cy / k.fy) - Eigen::Vector2d::Constant(grid.cell);
  grid.cols = static_cast<int>(std::ceil(frame.camera.width / cell_px)) + 2;
  grid.rows = static_cast<int>(std::ceil(frame.camera.height * k.fx / (k.fy * cell_px))) + 2;
  grid.nearest_m.assign(static_cast<size_t>(grid.cols) * grid.rows, 0.0f);
  grid.farthest_m = grid.nearest_m;
  std::vector<bool> unmeasured(grid.nearest_m.size(), false);
  const int step = std::max(1, pixel_step);
  for (int row = step / 2; row < frame.depth.rows; row += step)
    for (int col = step / 2; col < frame.depth.cols; col += step)
    {
      const long k = grid.cellOf(frame.camera.normalize(Eigen::Vector2d(col, row)));
      const double z = depthAt(frame.depth, row, col);
      if (k < 0)
        continue;
      if (!(z > 0.0 && std::isfinite(z)))
      {
        unmeasured[k] = true;
        continue;
      }
      if (grid.nearest_m[k] == 0.0f || z < grid.nearest_m[k])
        grid.nearest_m[k] = static_cast<float>(z);
      grid.farthest_m[k] = std::max(grid.farthest_m[k], static_cast<float>(z));
    }
  // A pixel without depth may look past everything the cell measured (beyond the depth's range): nothing is known
  // hidden there.
  for (size_t k = 0; k < unmeasured.size(); ++k)
    if (unmeasured[k])
      grid.farthest_m[k] = 0.0f;
  return grid;
}
}  // namespace insitu_calibration
