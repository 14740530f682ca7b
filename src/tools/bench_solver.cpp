// bench_solver: time of DLT-Lines with distortion in this library against a naive dense N x 12 formulation of the
// same system (rows stacked, products and an SVD), for 10^2..10^6 point-line constraints, on one core.
#include <chrono>
#include <iostream>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "command_line.h"
#include <Eigen/Geometry>

#include "insitu_calibration/solvers/dlt.h"
#include "insitu_calibration/solvers/normalization.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;
using Clock = std::chrono::steady_clock;

namespace
{
const char* kUsage = R"(Usage: bench_solver [--max-constraints N] [--seed S] [--repeat R]

Prints, for 10^2 .. N point-line constraints (default N = 10^6), the time of DLT-Lines with distortion in this
library (solveDltLinear: normalisation, accumulation, 12x12 generalised eigenproblem, lambda polish) against a naive
dense formulation of the same system (N x 12 matrices B1, B2; products; QZ; SVD of B1 + lambda B2), and
constraints per second. Two shapes of data: "dense" lines of 10 world points x 10 image parts (100 constraints per
line, like a surveyed edge), and "sparse" lines of 2 world points x 1 part (2 constraints per line, the worst case).
Single-threaded. The best of R runs is reported (default 3).
)";

double millisecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The same equations as the library, one row per (world point, part), then the textbook dense route.
double naiveSolve(const ic::CorrespondenceSet& data, const Eigen::Vector2d& center, double* lambda_out)
{
  std::vector<Eigen::Vector2d> image;
  std::vector<Eigen::Vector3d> world;
  size_t rows = 0;
  for (const auto& line : data.lines)
  {
    image.insert(image.end(), line.image.begin(), line.image.end());
    world.insert(world.end(), line.world.begin(), line.world.end());
    rows += line.constraintCount();
  }
  const ic::ImageNormalization in = ic::computeImageNormalization(image, center);
  const ic::WorldNormalization wn = ic::computeWorldNormalization(world);
  Eigen::MatrixXd b1(rows, 12);
  Eigen::MatrixXd b2(rows, 12);
  size_t r = 0;
  for (const auto& line : data.lines)
  {
    for (size_t j = 1; j < line.image.size(); ++j)
    {
      const Eigen::Vector2d a = in.apply(line.image[j - 1]);
      const Eigen::Vector2d b = in.apply(line.image[j]);
      const Eigen::Vector3d ld = a.homogeneous().cross(b.homogeneous());
      const double len = ld.head<2>().norm();
      const Eigen::Vector3d l = ld / len;
      const Eigen::Vector3d e = Eigen::Vector3d(a.y() * b.squaredNorm() - b.y() * a.squaredNorm(),
                                                b.x() * a.squaredNorm() - a.x() * b.squaredNorm(), 0.0) /
                                len;
      for (const auto& x : line.world)
      {
        const Eigen::Vector4d m = wn.apply(x).homogeneous();
        for (int c = 0; c < 4; ++c)
        {
          b1.block<1, 3>(r, 3 * c) = m(c) * l.transpose();
          b2.block<1, 3>(r, 3 * c) = m(c) * e.transpose();
        }
        ++r;
      }
    }
  }
  const Eigen::MatrixXd c11 = b1.transpose() * b1;
  const Eigen::MatrixXd c12 = b1.transpose() * b2;
  Eigen::GeneralizedEigenSolver<Eigen::MatrixXd> gep(c11, c12, false);
  double best_residual = std::numeric_limits<double>::infinity();
  double best_lambda = 0.0;
  for (int i = 0; i < 12; ++i)
  {
    if (std::abs(gep.betas()(i)) < 1e-12 * std::abs(gep.alphas()(i)) || std::abs(gep.alphas()(i).imag()) > 1e-8)
      continue;
    const double lambda = -gep.alphas()(i).real() / gep.betas()(i);
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(b1 + lambda * b2, Eigen::ComputeThinV);
    const double residual = svd.singularValues()(11);
    if (residual < best_residual)
    {
      best_residual = residual;
      best_lambda = lambda;
    }
  }
  *lambda_out = best_lambda * in.scale * in.scale;
  return best_residual;
}

// One row of the table: both solvers on n constraints of one shape, the best of `repeat` runs each (one for the
// naive solve at 10^6, which takes minutes). False when the library's solve fails.
bool benchmarkRow(const ic::CameraModel& camera, const ic::SyntheticCameraOptions& camera_options, bool dense, double n,
                  int repeat, std::mt19937& rng)
{
  ic::SyntheticLineOptions options;
  options.image_points_per_line = dense ? 11 : 2;
  options.world_points_per_line = dense ? 10 : 2;
  options.image_noise_px = 0.5;
  const int per_line = dense ? 100 : 2;
  options.lines = std::max(7, static_cast<int>(n / per_line));
  const ic::SyntheticLines lines =
      ic::makeSyntheticLines(camera, camera_options.image_width, camera_options.image_height, options, rng);
  ic::DltOptions dlt;
  dlt.method = ic::DltMethod::kLines;
  dlt.estimate_distortion = true;
  const Eigen::Vector2d center = camera.distortion().center;
  double library_ms = std::numeric_limits<double>::infinity();
  double library_lambda = 0.0;
  size_t constraints = 0;
  for (int k = 0; k < repeat; ++k)
  {
    const auto start = Clock::now();
    const auto solved = ic::solveDltLinear(lines.data, dlt, center);
    library_ms = std::min(library_ms, millisecondsSince(start));
    if (!solved)
    {
      std::cerr << "bench_solver: " << solved.error().describe() << "\n";
      return false;
    }
    library_lambda = solved->lambda;
    constraints = solved->constraints;
  }
  double naive_ms = std::numeric_limits<double>::infinity();
  double naive_lambda = 0.0;
  for (int k = 0; k < (n >= 1e6 ? 1 : repeat); ++k)
  {
    const auto start = Clock::now();
    naiveSolve(lines.data, center, &naive_lambda);
    naive_ms = std::min(naive_ms, millisecondsSince(start));
  }
  const double truth = camera.distortion().lambda;
  std::printf("| %-6s | %11zu | %7zu | %10.3f | %8.1f | %7.0fx | %23.3g | %12.2f %% / %10.2f %% |\n",
              dense ? "dense" : "sparse", constraints, lines.data.lines.size(), library_ms, naive_ms,
              naive_ms / library_ms, constraints / (library_ms * 1e-3),
              100.0 * std::abs(library_lambda - truth) / std::abs(truth),
              100.0 * std::abs(naive_lambda - truth) / std::abs(truth));
  std::fflush(stdout);
  return true;
}
}  // namespace

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv, {"max-constraints", "seed", "repeat"}, {});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  const double max_constraints = cli.number("max-constraints", 1e6);
  const unsigned seed = static_cast<unsigned>(cli.number("seed", 7));
  const int repeat = std::max(1, static_cast<int>(cli.number("repeat", 3)));
  if (!cli.error().empty())
  {
    std::cerr << "bench_solver: " << cli.error() << "\n\n" << kUsage;
    return 2;
  }
  std::mt19937 rng(seed);
  ic::SyntheticCameraOptions camera_options;
  const ic::CameraModel camera = ic::randomCamera(camera_options, rng);
  std::cout << "bench_solver: seed " << seed << ", camera fx " << camera.intrinsics().fx << " px, lambda "
            << camera.distortion().lambda << ", image noise 0.5 px, best of " << repeat << " runs, one thread\n\n";
  std::printf(
      "| shape  | constraints | lines   | library ms | naive ms | speed-up | constraints/s (library) | "
      "lambda error library / naive |\n");
  std::printf(
      "|--------|-------------|---------|------------|----------|----------|-------------------------|"
      "------------------------------|\n");
  for (const bool dense : {true, false})
    for (double n = 100; n <= max_constraints * 1.0001; n *= 10)
      if (!benchmarkRow(camera, camera_options, dense, n, repeat, rng))
        return 1;
  std::cout << "\nlambda error: against the true lambda. The library polishes the generalised eigenproblem's root to "
               "the joint least-squares minimum of ||(B1 + lambda B2) p||; the naive route keeps the paper's root of "
               "B1^T (B1 + lambda B2) p = 0.\n";
  return 0;
}
