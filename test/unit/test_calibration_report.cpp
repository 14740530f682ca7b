// The calibration report (survey/calibration_report.h): a synthetic camera calibrated from lines with three wrong
// correspondences, its report written into a temporary directory and read back: the parameters and the per-line
// residuals it shows are the result's, the wrong lines are the outliers, the figures load at their sizes, strings
// are escaped, and a directory that cannot be written gives an error and no file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/robust_statistics.h"
#include "insitu_calibration/survey/calibration_report.h"
#include "insitu_calibration/survey/overlay.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
constexpr unsigned kSeed = 11;
const std::set<size_t> kWrongLines = {2, 9, 17};

struct Calibrated
{
  ic::CameraModel truth;
  ic::CorrespondenceSet data;
  ic::CameraCalibration result;
};

// 40 lines at 0.5 px noise; three of them get another line's world points (wrong correspondences).
Calibrated calibrateSynthetic()
{
  std::mt19937 rng(kSeed);
  Calibrated c;
  c.truth = ic::randomCamera({}, rng);
  ic::SyntheticLineOptions options;
  options.lines = 40;
  options.image_points_per_line = 5;
  options.image_noise_px = 0.5;
  c.data = ic::makeSyntheticLines(c.truth, 1280, 960, options, rng).data;
  c.data.camera_name = "cam_a&b";
  for (const size_t i : kWrongLines)
    c.data.lines[i].world = c.data.lines[(i + 20) % c.data.lines.size()].world;
  const auto result = ic::calibrateCamera(c.data);
  EXPECT_TRUE(result) << result.error().describe();
  if (result)
    c.result = *result;
  return c;
}

ic::CalibrationReport makeReport(const Calibrated& c)
{
  ic::CalibrationReport report;
  report.camera_name = c.data.camera_name;
  report.image_width = c.data.image_width;
  report.image_height = c.data.image_height;
  report.source = "file <lines&points>.yaml";
  report.verdict = "accepted <script>alert('x')</script>";
  report.calibration = c.result;
  report.correspondences = c.data;
  for (size_t i = 0; i < c.data.lines.size(); ++i)
    (c.result.inlier_lines[i] ? report.matched_image_lines : report.unmatched_image_lines)
        .push_back(c.data.lines[i].image);
  return report;
}

std::string readText(const std::string& path)
{
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A table cell as a number: "n/a" is NaN.
double cellNumber(const std::string& cell)
{
  return cell == "n/a" ? NAN : std::stod(cell);
}

void expectSame(double expected, double shown, const std::string& what)
{
  if (std::isnan(expected))
    EXPECT_TRUE(std::isnan(shown)) << what;
  else
    EXPECT_NEAR(shown, expected, 1e-9 * std::max(1.0, std::abs(expected))) << what;
}

// The numbers of a parameter's value cell ("a, b, c") and its sigma.
std::pair<std::vector<double>, double> parameter(const std::string& html, const std::string& name)
{
  const std::regex row("<tr id=\"param-" + name + "\"><td>" + name +
                       "</td><td class=\"value\">([^<]*)</td><td class=\"sigma\">([^<]*)</td>");
  std::smatch m;
  EXPECT_TRUE(std::regex_search(html, m, row)) << "no row for " << name;
  if (m.empty())
    return {{}, NAN};
  std::vector<double> values;
  std::stringstream cells(m[1].str());
  for (std::string cell; std::getline(cells, cell, ',');)
    values.push_back(cellNumber(cell));
  return {values, cellNumber(m[2].str())};
}

class CalibrationReportTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    std::printf("seed %u\n", kSeed);
    directory_ = fs::temp_directory_path() / ("test_calibration_report_" + std::to_string(::getpid()));
    fs::remove_all(directory_);
  }
  void TearDown() override { fs::remove_all(directory_); }
  fs::path directory_;
};
}  // namespace

namespace
{
// The result's parameters and their sigmas, as the report shows them.
void expectParametersShown(const std::string& html, const Calibrated& c)
{
  const ic::Intrinsics& k = c.result.camera.intrinsics();
  const ic::CameraUncertainty& u = c.result.uncertainty;
  const std::vector<std::tuple<std::string, double, double>> scalars = {
      {"fx", k.fx, u.fx},
      {"fy", k.fy, u.fy},
      {"cx", k.cx, u.cx},
      {"cy", k.cy, u.cy},
      {"lambda", c.result.camera.distortion().lambda, u.lambda}};
  for (const auto& [name, value, sigma] : scalars)
  {
    const auto [shown, shown_sigma] = parameter(html, name);
    ASSERT_EQ(shown.size(), 1u) << name;
    expectSame(value, shown[0], name);
    expectSame(sigma, shown_sigma, name + " sigma");
  }
  const Eigen::Vector3d centre = c.result.camera.pose().center();
  const auto [position, position_sigma] = parameter(html, "position");
  ASSERT_EQ(position.size(), 3u);
  for (int i = 0; i < 3; ++i)
    expectSame(centre(i), position[i], "position");
  expectSame(u.position_m, position_sigma, "position sigma");
  const Eigen::Quaterniond q(c.result.camera.pose().worldFromCamera().linear());
  const auto [rotation, rotation_sigma] = parameter(html, "rotation");
  ASSERT_EQ(rotation.size(), 4u);
  expectSame(q.x(), rotation[0], "qx");
  expectSame(q.w(), rotation[3], "qw");
  expectSame(u.rotation_deg, rotation_sigma, "rotation sigma");
}

// One row per line, in order, with the result's residuals; the wrong lines are the outliers.
void expectLineRows(const std::string& html, const Calibrated& c)
{
  const std::regex line_row(
      "<tr id=\"line-(\\d+)\" class=\"(inlier|outlier)\"><td>\\d+</td><td>(\\d+)</td><td>(\\d+)</td><td>[a-z]+</td>"
      "<td>([^<]*)</td><td>([^<]*)</td><td>([^<]*)</td><td>([^<]*)</td>");
  // The refinement's per-line values follow the inliers' order (it ran on them alone); outliers have none.
  ASSERT_EQ(c.result.refinement->line_rms_px.size(), c.data.lines.size() - kWrongLines.size());
  size_t rows = 0, inlier_rank = 0;
  for (std::sregex_iterator it(html.begin(), html.end(), line_row), end; it != end; ++it, ++rows)
  {
    const std::smatch& m = *it;
    const size_t id = std::stoul(m[1].str());
    ASSERT_EQ(id, rows);
    EXPECT_EQ(m[2].str() == "inlier", kWrongLines.count(id) == 0) << "line " << id;
    EXPECT_EQ(std::stoul(m[3].str()), c.data.lines[id].image.size());
    EXPECT_EQ(std::stoul(m[4].str()), c.data.lines[id].world.size());
    expectSame(ic::rootMeanSquare(ic::lineResiduals(c.result.camera, c.data.lines[id])), cellNumber(m[5].str()),
               "RMS of line " + m[1].str());
    const bool inlier = c.result.inlier_lines[id];
    const auto refined = [&](const std::vector<double>& values) { return inlier ? values[inlier_rank] : NAN; };
    expectSame(refined(c.result.refinement->line_rms_px), cellNumber(m[6].str()), "refinement RMS");
    expectSame(refined(c.result.refinement->line_loo_rms_px), cellNumber(m[7].str()), "held-out RMS");
    expectSame(refined(c.result.refinement->line_influence), cellNumber(m[8].str()), "influence");
    inlier_rank += inlier ? 1 : 0;
  }
  EXPECT_EQ(rows, c.data.lines.size());
}

// Figures beside it, referred to by relative path, loading at their sizes.
void expectFiguresBeside(const std::string& html, const ic::ReportFiles& files, const fs::path& directory)
{
  for (const auto& [path, width, height] :
       std::vector<std::tuple<std::string, int, int>>{{files.overlay, 1280, 960},
                                                      {files.coverage, 1280, 960},
                                                      {files.residuals, ic::kReportChartWidth, ic::kReportChartHeight},
                                                      {files.lines, ic::kReportChartWidth, ic::kReportChartHeight}})
  {
    EXPECT_EQ(fs::path(path).parent_path(), directory);
    const cv::Mat figure = cv::imread(path, cv::IMREAD_COLOR);
    ASSERT_FALSE(figure.empty()) << path;
    EXPECT_EQ(figure.cols, width) << path;
    EXPECT_EQ(figure.rows, height) << path;
    EXPECT_NE(html.find("<img src=\"" + ic::escapeHtml(fs::path(path).filename().string()) + "\""), std::string::npos)
        << path;
  }
}
}  // namespace

TEST_F(CalibrationReportTest, ShowsTheResultsParametersAndLinesAndItsFiguresLoad)
{
  const Calibrated c = calibrateSynthetic();
  ASSERT_TRUE(c.result.uncertainty.available);
  // The calibration itself found the truth and the wrong lines (else the report would show nothing of interest).
  const ic::CameraErrors errors = ic::compareCameras(c.truth, c.result.camera);
  EXPECT_LT(std::abs(errors.focal_relative), 0.01);
  for (size_t i = 0; i < c.data.lines.size(); ++i)
    EXPECT_EQ(c.result.inlier_lines[i], kWrongLines.count(i) == 0) << "line " << i;

  const auto files = ic::writeCalibrationReport(directory_.string(), makeReport(c));
  ASSERT_TRUE(files) << files.error().describe();
  const std::string html = readText(files->html);
  ASSERT_FALSE(html.empty());

  expectParametersShown(html, c);
  expectLineRows(html, c);
  expectFiguresBeside(html, *files, directory_);
  EXPECT_NE(html.find("No survey: calibrated from"), std::string::npos);
  // Exactly the five files: no temporary left.
  EXPECT_EQ(std::distance(fs::directory_iterator(directory_), fs::directory_iterator()), 5);
}

TEST_F(CalibrationReportTest, EscapesStringsAndShowsTheSurvey)
{
  const Calibrated c = calibrateSynthetic();
  ic::CalibrationReport report = makeReport(c);
  report.survey = ic::ReportSurveySummary{123, 456};
  const auto files = ic::writeCalibrationReport(directory_.string(), report);
  ASSERT_TRUE(files) << files.error().describe();
  const std::string html = readText(files->html);
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_NE(html.find("accepted &lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("file &lt;lines&amp;points&gt;.yaml"), std::string::npos);
  EXPECT_NE(html.find("Calibration report: cam_a&amp;b"), std::string::npos);
  EXPECT_NE(html.find("<td>keyframes</td><td class=\"value\">123</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>map lines</td><td class=\"value\">456</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>matched lines</td><td class=\"value\">" +
                      std::to_string(c.data.lines.size() - kWrongLines.size()) + "</td>"),
            std::string::npos);
  EXPECT_EQ(html.find("No survey"), std::string::npos);
  EXPECT_NE(html.find("<p id=\"verdict\" class=\"accepted\">Accepted: "), std::string::npos);

  report.accepted = false;
  report.verdict = "only 5 lines matched (8 needed)";
  EXPECT_NE(ic::formatReportHtml(report).find(
                "<p id=\"verdict\" class=\"refused\">Refused (not saved): only 5 lines matched (8 needed)</p>"),
            std::string::npos);
}

TEST_F(CalibrationReportTest, ADirectoryThatCannotBeWrittenGivesAnErrorAndNoFile)
{
  const Calibrated c = calibrateSynthetic();
  fs::create_directories(directory_);
  const fs::path blocker = directory_ / "a_file";
  std::ofstream(blocker) << "not a directory";
  // Below a regular file: neither it nor its parents can be created.
  const auto below_file = ic::writeCalibrationReport((blocker / "reports").string(), makeReport(c));
  ASSERT_FALSE(below_file);
  EXPECT_EQ(below_file.error().code(), ic::ErrorCode::kIoError);
  EXPECT_NE(below_file.error().message().find("cannot write the calibration report of 'cam_a&b'"), std::string::npos)
      << below_file.error().message();
  EXPECT_NE(below_file.error().message().find((blocker / "reports").string()), std::string::npos);
  // The HTML's name taken by a directory: the figures (complete files) are written, the page is not, and no
  // temporary file stays behind.
  fs::create_directories(directory_ / "out" / "cam_a&b_report.html");
  const auto blocked_html = ic::writeCalibrationReport((directory_ / "out").string(), makeReport(c));
  ASSERT_FALSE(blocked_html);
  for (const auto& entry : fs::directory_iterator(directory_ / "out"))
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  EXPECT_TRUE(fs::is_directory(directory_ / "out" / "cam_a&b_report.html"));
  EXPECT_EQ(std::distance(fs::directory_iterator(directory_), fs::directory_iterator()), 2);  // a_file and out
}

// A refused result's camera may see some world points behind it: their residuals are infinite (calibrate_survey
// crashed in the residual histogram on generated building 409366). The report is written with them counted beyond
// the axis, and the figures load.
TEST_F(CalibrationReportTest, PointsBehindTheCameraAreCountedNotCrashedOn)
{
  const Calibrated c = calibrateSynthetic();
  ic::CalibrationReport report = makeReport(c);
  const ic::CameraModel& camera = report.calibration.camera;
  const Eigen::Vector3d behind = camera.pose().worldFromCamera() * Eigen::Vector3d(0.0, 0.0, -2.0);
  for (size_t i : {0, 3})
    for (Eigen::Vector3d& x : report.correspondences.lines[i].world)
      x = behind + 0.1 * (x - camera.pose().center()).normalized();
  ASSERT_FALSE(camera.project(report.correspondences.lines[0].world[0]));
  const auto written = ic::writeCalibrationReport(directory_.string(), report);
  ASSERT_TRUE(written) << written.error().message();
  const cv::Mat histogram = cv::imread((directory_ / "cam_a&b_report_residuals.png").string());
  EXPECT_FALSE(histogram.empty());
  EXPECT_NE(readText((directory_ / "cam_a&b_report.html").string()).find("residuals"), std::string::npos);
}

// A map edge along image row 480: seen as a black/white edge left of column 640, hidden behind a uniform grey
// foreground object right of it. The report's overlay draws the map line wide only where it is seen.
TEST(CalibrationReportOverlay, AMapEdgeHiddenBehindAForegroundObjectIsNotDrawnThroughIt)
{
  const ic::CameraModel camera({1000.0, 1000.0, 0.0, 640.0, 480.0}, {0.0, {640.0, 480.0}}, {});
  const std::vector<ic::Segment3d> map = {{Eigen::Vector3d(-3.0, 0.0, 5.0), Eigen::Vector3d(3.0, 0.0, 5.0)}};
  cv::Mat image(960, 1280, CV_8UC1, cv::Scalar(0));
  image(cv::Rect(0, 481, 1280, 479)).setTo(255);   // the edge between rows 480 and 481
  image(cv::Rect(640, 400, 640, 160)).setTo(128);  // the foreground object over its right half
  const auto red = [](const cv::Mat& overlay, int x, int y) {
    const cv::Vec3b p = overlay.at<cv::Vec3b>(y, x);
    return p[2] > 150 && p[1] < 100 && p[0] < 100;
  };
  // Wide (5 px at this size) where seen; where hidden at most the thin dashes (2 px) on the line itself.
  const cv::Mat overlay = ic::drawOverlayWithHiddenEdges(image, 1280, 960, camera, map, {}, {});
  size_t seen_wide = 0, hidden_wide = 0;
  for (int x = 100; x < 560; ++x)
    seen_wide += red(overlay, x, 478) && red(overlay, x, 482) ? 1 : 0;
  for (int x = 720; x < 1200; ++x)
    hidden_wide += red(overlay, x, 478) || red(overlay, x, 482) ? 1 : 0;
  EXPECT_GT(seen_wide, 440u);
  EXPECT_EQ(hidden_wide, 0u);
  // The plain overlay draws it wide all the way across (what the report's must not do).
  const cv::Mat plain = ic::drawOverlay(image, 1280, 960, camera, map, {});
  EXPECT_TRUE(red(plain, 900, 479) && red(plain, 900, 481));
}

// The report's overlay of a result the final check assessed shows what it counted: a counted map line wide where an
// image edge lies under it and thin where none does; a floor line it left out and a map line it never saw (hidden)
// in blue dashes, not red.
TEST(CalibrationReportOverlay, ShowsWhatTheFinalCheckCountedAndWhatItLeftOut)
{
  const ic::CameraModel camera({1000.0, 1000.0, 0.0, 640.0, 480.0}, {0.0, {640.0, 480.0}}, {});
  const ic::Segment3d counted{Eigen::Vector3d(-3.0, 0.0, 5.0), Eigen::Vector3d(3.0, 0.0, 5.0)};   // row 480
  const ic::Segment3d left_out{Eigen::Vector3d(-3.0, 1.0, 5.0), Eigen::Vector3d(3.0, 1.0, 5.0)};  // row 680
  const ic::Segment3d hidden{Eigen::Vector3d(-3.0, -1.0, 5.0), Eigen::Vector3d(3.0, -1.0, 5.0)};  // row 280
  cv::Mat image(960, 1280, CV_8UC1, cv::Scalar(0));
  image(cv::Rect(0, 481, 640, 479)).setTo(255);  // an edge under the counted line's left half only
  std::vector<ic::EdgeSamples> checked = ic::sampleEdgeSupport(image, camera, 1280, 960, {counted, left_out});
  ASSERT_EQ(checked.size(), 2u);
  checked[1].counted = false;  // as the check leaves out a floor line where the floor looks plain
  const cv::Mat overlay =
      ic::drawFinalCheckOverlay(image, 1280, 960, camera, {counted, left_out, hidden}, checked, {}, {});
  const auto red = [&](int x, int y) {
    const cv::Vec3b p = overlay.at<cv::Vec3b>(y, x);
    return p[2] > 150 && p[1] < 100 && p[0] < 100;
  };
  const auto blue = [&](int x, int y) {
    const cv::Vec3b p = overlay.at<cv::Vec3b>(y, x);
    return p[0] > 150 && p[2] < 120 && p[0] > p[2] + 80;
  };
  const auto count = [](int from, int to, const std::function<bool(int)>& test) {
    size_t n = 0;
    for (int x = from; x < to; ++x)
      n += test(x) ? 1 : 0;
    return n;
  };
  // Counted, on an edge: wide (5 px at this size).
  EXPECT_GT(count(100, 560, [&](int x) { return red(x, 478) && red(x, 482); }), 440u);
  // Counted: no blue dashes show through it.
  EXPECT_EQ(count(100, 1200, [&](int x) { return blue(x, 479) || blue(x, 480) || blue(x, 481); }), 0u);
  // Counted, no edge: thin red on the line, not wide.
  EXPECT_GT(count(720, 1200, [&](int x) { return red(x, 480) || red(x, 481); }), 440u);
  EXPECT_EQ(count(720, 1200, [&](int x) { return red(x, 477) || red(x, 483); }), 0u);
  // Left out and hidden: blue dashes (about half of their length), never red.
  for (const int row : {680, 280})
  {
    const size_t blue_columns =
        count(100, 1200, [&](int x) { return blue(x, row - 1) || blue(x, row) || blue(x, row + 1); });
    EXPECT_GT(blue_columns, 350u) << "row " << row;
    EXPECT_LT(blue_columns, 800u) << "row " << row;  // dashed
    EXPECT_EQ(count(100, 1200, [&](int x) { return red(x, row - 1) || red(x, row) || red(x, row + 1); }), 0u)
        << "row " << row;
  }
  // Without an image: the plain overlay (every map line red).
  const cv::Mat plain = ic::drawFinalCheckOverlay(cv::Mat(), 1280, 960, camera, {counted, hidden}, checked, {}, {});
  const cv::Vec3b p = plain.at<cv::Vec3b>(280, 900);
  EXPECT_TRUE(p[2] > 150 && p[1] < 100 && p[0] < 100);
}
