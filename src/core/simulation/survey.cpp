#include "insitu_calibration/simulation/survey.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <tuple>

#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/simulation/random.h"
#include "insitu_calibration/simulation/sensor_models.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "io/yaml_util.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
enum StreamKind : uint64_t
{
  kDepthStream = 1,
  kXtionRgbStream = 2,
  kFixedStream = 3,
  kDriftStream = 4,
  kLocalizationStream = 5,
};

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t)
{
  return std::chrono::duration<double>(Clock::now() - t).count();
}

int64_t periodNs(double rate_hz)
{
  return std::llround(1e9 / rate_hz);
}

// x, y and yaw each a stationary first-order Gauss-Markov process (exponential correlation tau_s), sampled every
// dt_s, starting from its stationary distribution.
std::vector<Pose2d> localizationErrors(const SimulationOptions& o, size_t count, double dt_s)
{
  FastRandom rng(streamSeed(o.seed, kLocalizationStream));
  const double sigma_yaw = o.localization_sigma_deg * M_PI / 180.0;
  const double a = std::exp(-dt_s / std::max(1e-9, o.localization_tau_s));
  const double b = std::sqrt(std::max(0.0, 1.0 - a * a));
  std::vector<Pose2d> out;
  Pose2d e{o.localization_sigma_m * rng.exactGaussian(), o.localization_sigma_m * rng.exactGaussian(),
           sigma_yaw * rng.exactGaussian()};
  for (size_t i = 0; i < count; ++i)
  {
    if (i > 0)
    {
      e.x = a * e.x + b * o.localization_sigma_m * rng.exactGaussian();
      e.y = a * e.y + b * o.localization_sigma_m * rng.exactGaussian();
      e.yaw = a * e.yaw + b * sigma_yaw * rng.exactGaussian();
    }
    out.push_back(e);
  }
  return out;
}
}  // namespace

SurveySimulator::SurveySimulator(World world, const SimulationOptions& options)
    : world_(std::make_unique<World>(std::move(world))),
      renderer_(std::make_unique<Renderer>(*world_)),
      options_(options),
      trajectory_(world_->route)
{}

Expected<SurveySimulator> SurveySimulator::create(World world, const SimulationOptions& options)
{
  if (!(options.duration_s > 0.0 && options.duration_s <= 24 * 3600.0))
    return Error(ErrorCode::kInvalidInput, "the duration must be positive (and at most a day)");
  if (!(options.rate_hz > 0.0 && options.rate_hz <= 1000.0))
    return Error(ErrorCode::kInvalidInput, "the RGB-D rate must be in (0, 1000] Hz");
  if (!(options.localization_sigma_m >= 0.0 && options.localization_sigma_deg >= 0.0 &&
        options.localization_tau_s > 0.0))
    return Error(ErrorCode::kInvalidInput,
                 "the localisation error needs sigmas >= 0 and a positive correlation time (--localization-error)");
  if (!(options.tf_min_rate_hz > 0.0))
    return Error(ErrorCode::kInvalidInput, "the tf rate must be positive");
  if (options.fixed_rate_hz && !(*options.fixed_rate_hz > 0.0 && *options.fixed_rate_hz <= 1000.0))
    return Error(ErrorCode::kInvalidInput, "the fixed cameras' rate must be in (0, 1000] Hz");
  SurveySimulator s(std::move(world), options);
  s.duration_ns_ = std::llround(options.duration_s * 1e9);
  const int64_t image_period = periodNs(options.rate_hz);
  const int64_t m =
      std::max<int64_t>(1, static_cast<int64_t>(std::ceil(options.tf_min_rate_hz / options.rate_hz - 1e-9)));
  s.tf_period_ns_ = std::max<int64_t>(1, image_period / m);
  const int64_t aligned_image_period = s.tf_period_ns_ * m;

  s.events_.push_back({0, SurveyEventKind::kStaticTf, -1, 0});
  for (int64_t t = 0, i = 0; t <= s.duration_ns_; t += s.tf_period_ns_, ++i)
  {
    s.tf_stamps_.push_back(t);
    s.events_.push_back({t, SurveyEventKind::kTf, -1, static_cast<int>(i)});
  }
  for (int64_t t = 0, i = 0; t < s.duration_ns_; t += aligned_image_period, ++i)
  {
    s.xtion_stamps_.push_back(t);
    s.events_.push_back({t, SurveyEventKind::kXtion, -1, static_cast<int>(i)});
  }
  for (size_t c = 0; c < s.world_->fixed_cameras.size(); ++c)
  {
    const int64_t period = periodNs(s.fixedRateHz(static_cast<int>(c)));
    s.fixed_stamps_.emplace_back();
    for (int64_t t = std::llround(s.world_->fixed_cameras[c].phase_s * 1e9), i = 0; t < s.duration_ns_;
         t += period, ++i)
    {
      s.fixed_stamps_[c].push_back(t);
      s.events_.push_back({t, SurveyEventKind::kFixed, static_cast<int>(c), static_cast<int>(i)});
    }
  }
  std::stable_sort(s.events_.begin(), s.events_.end(), [](const SurveyEvent& a, const SurveyEvent& b) {
    return std::make_tuple(a.stamp_ns, static_cast<int>(a.kind), a.camera) <
           std::make_tuple(b.stamp_ns, static_cast<int>(b.kind), b.camera);
  });

  if (options.odom_drift)
  {
    FastRandom rng(streamSeed(options.seed, kDriftStream));
    const double dt = s.tf_period_ns_ * 1e-9;
    Pose2d d;
    for (size_t i = 0; i < s.tf_stamps_.size(); ++i)
    {
      if (i > 0)
      {
        d.x += options.odom_drift_xy * std::sqrt(dt) * rng.exactGaussian();
        d.y += options.odom_drift_xy * std::sqrt(dt) * rng.exactGaussian();
        d.yaw += options.odom_drift_yaw_deg * M_PI / 180.0 * std::sqrt(dt) * rng.exactGaussian();
      }
      s.drift_.push_back(d);
    }
  }
  if (options.localization_sigma_m > 0.0 || options.localization_sigma_deg > 0.0)
    s.localization_ = localizationErrors(options, s.tf_stamps_.size(), s.tf_period_ns_ * 1e-9);
  s.fixed_clean_.resize(s.world_->fixed_cameras.size());
  return s;
}

double SurveySimulator::fixedRateHz(int camera) const
{
  return options_.fixed_rate_hz ? *options_.fixed_rate_hz : world_->fixed_cameras[camera].rate_hz;
}

std::vector<NamedTransform> SurveySimulator::staticTransforms() const
{
  return xtionStaticTransforms(world_->xtion);
}

Eigen::Isometry3d SurveySimulator::mapFromBase(int64_t stamp_ns) const
{
  return trajectory_.mapFromBase(static_cast<double>(stamp_ns) * 1e-9);
}

Pose2d SurveySimulator::localizationError(int64_t stamp_ns) const
{
  if (localization_.empty())
    return {};
  return localization_[std::min(localization_.size() - 1,
                                static_cast<size_t>(std::max<int64_t>(0, stamp_ns / tf_period_ns_)))];
}

Eigen::Isometry3d SurveySimulator::localizedMapFromBase(int64_t stamp_ns) const
{
  const Pose2d truth = trajectory_.at(static_cast<double>(stamp_ns) * 1e-9);
  const Pose2d error = localizationError(stamp_ns);
  return pose2dToIsometry({truth.x + error.x, truth.y + error.y, truth.yaw + error.yaw});
}

std::vector<NamedTransform> SurveySimulator::dynamicTransforms(int64_t stamp_ns) const
{
  Eigen::Isometry3d odom_from_map = Eigen::Isometry3d::Identity();
  if (!drift_.empty())
  {
    const size_t i = std::min(drift_.size() - 1, static_cast<size_t>(std::max<int64_t>(0, stamp_ns / tf_period_ns_)));
    odom_from_map = pose2dToIsometry(drift_[i]);
  }
  // Odometry follows the true motion (with its drift); the localiser's map -> odom makes map -> base_link what it
  // believes.
  const Eigen::Isometry3d odom_from_base = odom_from_map * mapFromBase(stamp_ns);
  return {{"map", "odom", localizedMapFromBase(stamp_ns) * odom_from_base.inverse()},
          {"odom", "base_link", odom_from_base}};
}

ViewCamera SurveySimulator::xtionCamera(int64_t stamp_ns) const
{
  const XtionConfig& x = world_->xtion;
  ViewCamera v;
  v.width = x.width;
  v.height = x.height;
  v.intrinsics = x.intrinsics;
  v.world_from_camera = mapFromBase(stamp_ns) * baseFromRgbOptical(x);
  return v;
}

ViewCamera SurveySimulator::fixedCamera(int camera) const
{
  const SimulatedFixedCamera& c = world_->fixed_cameras[camera];
  return ViewCamera::fromModel(c.camera, c.width, c.height);
}

XtionFrame SurveySimulator::xtionFrame(int index) const
{
  const XtionConfig& x = world_->xtion;
  XtionFrame f;
  f.stamp_ns = xtion_stamps_.at(index);
  const ViewCamera cam = xtionCamera(f.stamp_ns);
  f.map_from_optical = cam.world_from_camera;
  RenderOptions ro;
  ro.supersampling = x.supersampling;
  auto t0 = Clock::now();
  RenderedView view = renderer_->render(cam, ro);
  timings_.xtion_render_s += secondsSince(t0);
  t0 = Clock::now();
  f.depth_mm = simulateXtionDepth(view, *world_, cam, x.depth, options_.depth_noise,
                                  streamSeed(options_.seed, kDepthStream, 0, index), world_->appearance.depth);
  const CameraAppearance& look = world_->appearance.xtion_rgb;
  f.rgb = applyCameraOptics(view.rgb, look, cam);
  if (options_.image_noise && x.rgb_noise_sigma > 0.0)
    f.rgb = addImageNoise(f.rgb, {x.rgb_noise_sigma, 0.0}, streamSeed(options_.seed, kXtionRgbStream, 0, index));
  if (look.jpeg_quality > 0)
    f.rgb = jpegRoundTrip(f.rgb, look.jpeg_quality);
  timings_.xtion_sensor_s += secondsSince(t0);
  ++timings_.xtion_frames;
  return f;
}

const cv::Mat& SurveySimulator::fixedCleanImage(int camera) const
{
  cv::Mat& clean = fixed_clean_.at(camera);
  if (clean.empty())
  {
    const auto t0 = Clock::now();
    RenderOptions ro;
    ro.supersampling = world_->fixed_cameras[camera].supersampling;
    const ViewCamera view = fixedCamera(camera);
    clean = applyCameraOptics(renderer_->render(view, ro).rgb, world_->fixed_cameras[camera].appearance, view);
    timings_.fixed_render_s += secondsSince(t0);
  }
  return clean;
}

FixedFrame SurveySimulator::fixedFrame(int camera, int index) const
{
  FixedFrame f;
  f.camera = camera;
  f.stamp_ns = fixed_stamps_.at(camera).at(index);
  const cv::Mat& clean = fixedCleanImage(camera);
  const auto t0 = Clock::now();
  f.image = options_.image_noise ? addImageNoise(clean, world_->fixed_cameras[camera].noise,
                                                 streamSeed(options_.seed, kFixedStream, camera, index))
                                 : clean.clone();
  if (const int quality = world_->fixed_cameras[camera].appearance.jpeg_quality; quality > 0)
    f.image = jpegRoundTrip(f.image, quality);
  timings_.fixed_noise_s += secondsSince(t0);
  ++timings_.fixed_frames;
  return f;
}

CalibrationFile SurveySimulator::groundTruth(int camera) const
{
  const SimulatedFixedCamera& c = world_->fixed_cameras.at(camera);
  CalibrationFile f;
  f.camera_name = c.name;
  f.image_width = c.width;
  f.image_height = c.height;
  f.world_frame = "map";
  f.camera = c.camera;
  return f;
}

void renderWholeSurvey(const SurveySimulator& survey)
{
  for (const SurveyEvent& e : survey.events())
  {
    if (e.kind == SurveyEventKind::kXtion)
      survey.xtionFrame(e.index);
    else if (e.kind == SurveyEventKind::kFixed)
      survey.fixedFrame(e.camera, e.index);
  }
}

std::string truthDirectoryFor(const std::string& bag_path)
{
  const std::filesystem::path p(bag_path);
  return (p.parent_path() / (p.stem().string() + "_truth")).string();
}

namespace
{
// Per RGB-D frame: [stamp (s since the epoch), x error (m), y error (m), yaw error (deg)].
Status writeLocalizationErrors(const SurveySimulator& survey, const std::string& path)
{
  YAML::Emitter out;
  out.SetDoublePrecision(16);
  out << YAML::BeginMap << YAML::Key << "frames" << YAML::Value << YAML::BeginSeq;
  for (const int64_t t : survey.xtionStamps())
  {
    const Pose2d e = survey.localizationError(t);
    out << YAML::Flow << YAML::BeginSeq << (survey.options().start_time_ns + t) * 1e-9 << e.x << e.y
        << e.yaw * 180.0 / M_PI << YAML::EndSeq;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return writeFileAtomically(path, std::string(out.c_str()) + "\n");
}
}  // namespace

Status writeGroundTruth(const SurveySimulator& survey, const std::string& directory,
                        const std::vector<std::string>& topics)
{
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec)
    return Error(ErrorCode::kIoError, "cannot create " + directory + ": " + ec.message());
  const World& world = survey.world();
  for (size_t c = 0; c < world.fixed_cameras.size(); ++c)
  {
    const Status s =
        saveCalibrationFile(directory + "/" + world.fixed_cameras[c].name + ".yaml", survey.groundTruth(c));
    if (!s)
      return s;
  }
  if (const Status s = saveTrueEdges(directory + "/edges.yaml", computeTrueEdges(world), world.name); !s)
    return s;

  const SimulationOptions& o = survey.options();
  const XtionConfig& x = world.xtion;
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  out << YAML::Key << "world" << YAML::Value << world.name;
  out << YAML::Key << "world_file" << YAML::Value << world.source;
  out << YAML::Key << "seed" << YAML::Value << o.seed;
  out << YAML::Key << "start_time_ns" << YAML::Value << o.start_time_ns;
  out << YAML::Key << "duration_s" << YAML::Value << o.duration_s;
  out << YAML::Key << "rgbd_rate_hz" << YAML::Value << o.rate_hz;
  out << YAML::Key << "rgbd_frames" << YAML::Value << survey.xtionFrameCount();
  out << YAML::Key << "tf_rate_hz" << YAML::Value << survey.tfRateHz();
  out << YAML::Key << "depth_noise" << YAML::Value << o.depth_noise;
  out << YAML::Key << "image_noise" << YAML::Value << o.image_noise;
  out << YAML::Key << "odom_drift" << YAML::Value << o.odom_drift;
  out << YAML::Key << "localization_sigma_m" << YAML::Value << o.localization_sigma_m;
  out << YAML::Key << "localization_sigma_deg" << YAML::Value << o.localization_sigma_deg;
  out << YAML::Key << "localization_tau_s" << YAML::Value << o.localization_tau_s;
  out << YAML::Key << "xtion" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "frame_id" << YAML::Value << "camera_rgb_optical_frame";
  out << YAML::Key << "width" << YAML::Value << x.width;
  out << YAML::Key << "height" << YAML::Value << x.height;
  yaml_util::emitMatrix(out, "camera_matrix", x.intrinsics.matrix());
  out << YAML::Key << "depth_sigma_coefficient" << YAML::Value << x.depth.sigma_coefficient;
  out << YAML::Key << "depth_max_range_m" << YAML::Value << x.depth.max_range_m;
  out << YAML::EndMap;
  out << YAML::Key << "fixed_cameras" << YAML::Value << YAML::BeginSeq;
  for (size_t c = 0; c < world.fixed_cameras.size(); ++c)
  {
    const SimulatedFixedCamera& f = world.fixed_cameras[c];
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << f.name;
    out << YAML::Key << "rate_hz" << YAML::Value << survey.fixedRateHz(static_cast<int>(c));
    out << YAML::Key << "frame_id" << YAML::Value << f.name + "_optical_frame";
    out << YAML::Key << "truth" << YAML::Value << f.name + ".yaml";
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "edges" << YAML::Value << "edges.yaml";
  out << YAML::Key << "topics" << YAML::Value << topics;
  out << YAML::EndMap;
  if (const Status s = writeFileAtomically(directory + "/survey.yaml", std::string(out.c_str()) + "\n"); !s)
    return s;
  return writeLocalizationErrors(survey, directory + "/localization.yaml");
}

Expected<std::vector<LocalizationSample>> loadLocalizationErrors(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  // The simulator's own output, as long as the survey: no size cap, only the aliases' expansion is bounded.
  const auto tree = yaml_util::parseYamlTree(*text, 2 * text->size() + 1024, path);
  if (!tree)
    return tree.error();
  try
  {
    std::vector<LocalizationSample> out;
    for (const auto& row : tree->root()["frames"])
    {
      if (row.size() != 4)
        return Error(ErrorCode::kParseError, path + ": each frame needs [stamp, x, y, yaw_deg]");
      out.push_back(
          {row[0].as<double>(), {row[1].as<double>(), row[2].as<double>(), row[3].as<double>() * M_PI / 180.0}});
    }
    return out;
  }
  catch (const YAML::Exception& e)
  {
    return Error(ErrorCode::kParseError, path + ": " + e.what());
  }
}

const LocalizationSample& nearestLocalizationSample(const std::vector<LocalizationSample>& errors, double stamp)
{
  const auto it = std::lower_bound(errors.begin(), errors.end(), stamp,
                                   [](const LocalizationSample& s, double t) { return s.stamp < t; });
  if (it == errors.end() || (it != errors.begin() && std::abs((it - 1)->stamp - stamp) < it->stamp - stamp))
    return *(it - 1);
  return *it;
}

PlacementLimit placementLimit(const std::vector<LocalizationSample>& errors, const std::vector<double>& stamps,
                              const std::vector<Eigen::Vector3d>& pivots, const Eigen::Vector3d& point)
{
  if (errors.empty())
    return {};
  std::vector<Pose2d> keyframe_errors;
  for (double stamp : stamps)
    keyframe_errors.push_back(nearestLocalizationSample(errors, stamp).error);
  return placementLimit(keyframe_errors, pivots, point);
}

PlacementLimit placementLimit(const std::vector<Pose2d>& keyframe_errors, const std::vector<Eigen::Vector3d>& pivots,
                              const Eigen::Vector3d& point)
{
  PlacementLimit limit;
  const size_t n = std::min(keyframe_errors.size(), pivots.size());
  if (n == 0)
    return limit;
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (size_t k = 0; k < n; ++k)
  {
    const Pose2d& e = keyframe_errors[k];
    const Eigen::Vector2d arm = (point - pivots[k]).head<2>();
    shift += (Eigen::Rotation2Dd(e.yaw) * arm - arm) + Eigen::Vector2d(e.x, e.y);
    limit.rotation_rad += e.yaw;
  }
  limit.position_m = shift.norm() / static_cast<double>(n);
  limit.rotation_rad = std::abs(limit.rotation_rad) / static_cast<double>(n);
  return limit;
}

}  // namespace simulation
}  // namespace insitu_calibration
