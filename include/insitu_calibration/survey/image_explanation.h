// The final check of a fixed camera's calibration: does the camera explain the image as a whole, not only the lines
// it was fitted to?
//  - Overlay agreement: every map line the camera sees, projected through it, should lie on an edge of the image
//    (a gradient across the projected line, within 1 px, along the line's normal). The same test 4 px to either side
//    measures how often a line meets an edge by chance (texture, clutter). A wrong camera puts the lines it was not
//    matched to on plain wall and floor.
//    Floor lines where the floor looks plain are left out: the joints of planks, tiles and carpet that the Xtion
//    saw from 1-2 m are often below a fixed camera's resolution from 3-10 m, so a right camera's floor lines find no
//    edge there; floor lines that fall within 4 px of edges parallel to them (joints the camera resolves) still
//    count.
//  - Where the image beside a line is plain, the line itself must mostly lie on an edge (the isolated agreement):
//    texture beside the lines raises the chance level for right and wrong cameras alike, plain surroundings do not.
//    A line whose plain samples show, averaged along it, a step across it lies on a faint crease: they count as on
//    an edge (faint_edge_gradient).
//  - Held-out lines: each matched line's residual had it been left out of the fit (the refinement's linearised
//    leave-one-out), against the residual level of the fit: a camera pulled onto a few wrong matches predicts its
//    other lines badly.
#ifndef INSITU_CALIBRATION_SURVEY_IMAGE_EXPLANATION_H
#define INSITU_CALIBRATION_SURVEY_IMAGE_EXPLANATION_H

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/map/joint_lines.h"
#include "insitu_calibration/refine/refinement.h"

namespace insitu_calibration
{
struct ImageExplanationOptions
{
  double sample_step_px = 3.0;    // along each projected map line
  double min_gradient = 4.0;      // grey levels per px across the line for an edge
  double min_alignment = 0.8;     // |gradient . normal| / |gradient|
  double chance_offset_px = 4.0;  // where the chance level is measured
  // The chance level is measured clear of the other map lines' projections (a band of chance_mapped_radius_px
  // about each): an edge there is that line's, which the camera explains, not one met by chance. Where another map
  // line projects near the place chance_offset_px beside a sample, the nearest place up to 1.5 chance_offset_px from
  // the line clear of every band (its own line's included) is taken instead. A sample with no such place on either
  // side lies amid other map lines (a texture the map holds, finer than the bands): there is no telling what meets an
  // edge by chance, and it is left out. The places depend on the camera's own projection, not on the image: a wrong
  // camera's meet image edges as often as they would anywhere. 3 px: the check's edge probe reaches 1 px either side
  // of a place, and a blurred 1 px joint gives a gradient over 4 grey levels per px up to 2 px from its centre.
  // Measured: a room's right camera (brick joints 4-6 px apart in a 640x480 view, all mapped) was refused with its
  // chance level at 42 % (excess 0.39) counting the joints' edges beside its lines as chance. Only when at least
  // min_chance_sides sides are measured is the chance level taken from them (else 4 px beside every counted sample).
  // 0: off, 4 px beside every sample, none left out (parameter chance_mapped_radius).
  double chance_mapped_radius_px = 3.0;
  size_t min_chance_sides = 200;
  // With chance_mapped_radius_px: a sample counts only where both its sides have a clear place (false: where either
  // has). A line along a texture's border keeps a clear place on its plain side while it lies in the texture, and a
  // camera a few px off matches its lines to the texture's edges there, against a chance level measured on the plain
  // side only: of five wrong alternatives (0.10-0.35 m off) that passed the check with either side, three fail with
  // both (parameter chance_both_sides).
  bool chance_needs_both_sides = true;
  double min_line_length_px = 20.0;  // shorter projections are not assessed
  // A map line with both ends within floor_tolerance_m of the floor plane (z = floor_height_m in the map, as
  // FloorLineOptions) is a floor line. It is left out where the floor looks plain: fewer than plain_floor_on_edge
  // of its samples on an edge and fewer than plain_floor_beside beside it (a joint this camera does not resolve;
  // a wrong camera's floor lines on floor texture it resolves near them usually have edges beside them). On the
  // tuning data (buildings 3001-3014 and the eighth fresh set, docs/measurements.md) it turned three refused right
  // cameras into accepted ones (two on plank floors: 20 % and 60 % of all their samples on edges, 62 % and 80 %
  // without their plain-floor lines); no wrong result or alternative passed with them left out that did not pass
  // with them.
  // false: every floor line counts (parameter plain_floor_test).
  bool leave_out_plain_floor = true;
  double floor_height_m = 0.0;      // the survey sets both as its floor lines' (FloorLineOptions: floor_height_m,
  double floor_tolerance_m = 0.05;  // min_edge_height_m / 2)
  double plain_floor_on_edge = 0.25;
  double plain_floor_beside = 0.08;
  // With plain_floor_by_sample, floor samples are left out one by one where the floor looks plain there (no edge on
  // the sample nor chance_offset_px to either side of it) instead of whole floor lines by plain_floor_on_edge and
  // plain_floor_beside: a joint this camera resolves near it and not farther away then counts where it is resolved.
  // Measured (docs/measurements.md, "Why true cameras fail the final check"): of 38 true cameras 5 fail the check
  // as it is, 2 with it; none of 256 fitted wrong cameras (the ambiguity test's alternatives) changes its verdict. The
  // whole pipeline (docs/measurements.md, "Fusion measured again"): set A 192809 cam_b and fresh set C 394178 cam_a,
  // both right and refused by the check without it, accepted; no camera lost, none wrong. On since 2026-12-03
  // (parameter plain_floor_samples).
  bool plain_floor_by_sample = true;
  // The ceiling's height in the map, when known (the survey measures it from its depth lines for each calibration,
  // map/ceiling_lines.h). With plain_ceiling its lines are tested as floor lines are (left out where the image looks
  // plain there, within floor_tolerance_m of the plane): the joints of ceiling tiles and panels that the Xtion,
  // pitched up, mapped from below a camera sees at a grazing angle from just under the ceiling, often below its
  // resolution. Measured on fresh set X, where the survey hints had the Xtion pitched up, and on set V's surveys
  // against the world (docs/measurements.md, "The depth lines' reach"); parameter plain_ceiling_samples.
  std::optional<double> ceiling_height_m;
  bool plain_ceiling = true;
  // Only ceiling lines inside a grid are tested so (at least two parallel ceiling lines within this spacing on
  // either side: tile and panel joints); a lone ceiling line, such as the ceiling's border with a wall, always counts,
  // so that a wrong camera's projection of it onto plain wall or ceiling speaks against it.
  TextureLineOptions ceiling_grid = {2, 1.25, 3.0, 0.3, 0.005};
  // Texture lines (map/joint_lines.h: joints of bricks, tiles, planks or panelling, four or more parallel map lines
  // side by side) are left out sample by sample where the image shows no edge on or beside them, as plain floor
  // samples are: such joints the Xtion mapped from 1-2 m are often below a fixed camera's resolution from 3-10 m (a
  // right camera's brick lines then find no edge); a lone structural edge (a corner, a door frame) always counts.
  // Off by default (min_neighbours 0; parameter texture_min_neighbours, 4 turns it on): measured, it lets true cameras
  // of brick corridors pass the check but also fitted wrong cameras that failed it (0.47-0.49 m off), and it changed
  // no calibration of the six buildings measured (docs/measurements.md, "Wall texture in the final check").
  TextureLineOptions texture = {0};
  // Left out only when at least this many map lines remain (fewer are too little to judge the camera on: every
  // floor line counts then).
  size_t min_lines_without_plain_floor = 30;
  // Acceptance (0 disables a test): the share a of projected map-line samples on edges, and its excess over the
  // chance level c beside the lines, (a - c) / (1 - c) (as Cohen's kappa: a textured view has a high c).
  // The default world's true cameras with the edges they see: a 76-80 %, excess 0.69-0.77; wrong cameras a 13-55 %,
  // excess at most 0.37 (one floor tile off); calibrated default-world cameras a 74-97 %, excess 0.67-0.95; generated
  // tuning buildings (seeds 3001-3008): correct results a 68-99 %, accepted wrong ones a 27-62 %, excess <= 0.49.
  // A ratio a / c >= 2 refused a correct camera of a textured office (a 91 %, c 58 %; seed 2005 of the README set).
  double min_overlay_agreement = 0.6;
  double min_overlay_excess = 0.5;
  // Where the image beside a line is plain (no edge 4 px to either side), a right camera's line lies on an edge;
  // a wrong camera's falls on plain wall or floor. The share of such samples on an edge (ImageExplanation::
  // isolated_agreement; lines whose plain samples are left out do not count) must reach min_isolated_agreement when
  // there are at least min_isolated_samples of them. It guards where the floor and ceiling rules leave out what would
  // speak against a wrong camera: on generated buildings' surveys against the world (docs/measurements.md, "The
  // isolated agreement") right results had 43-77 % (the default world's true cameras 76-86 %), while 7 of the 15 fitted
  // wrong alternatives that passed the other tests had 5-24 %. 0 disables.
  double min_isolated_agreement = 0.25;
  size_t min_isolated_samples = 200;
  // A map line's samples that find no edge on them nor beside them one by one may still lie on a faint edge: a
  // crease between two faces painted alike (a column's corner: a step of 5-10 grey levels blurred over 3 px, under
  // min_gradient at any one sample). Averaged over those samples along the line, the step across it stands out of
  // the image noise: where the mean gradient across the line (signed, within 1 px of it) reaches faint_edge_gradient,
  // faint_edge_significance standard errors, and faint_edge_beside_ratio times the mean gradient chance_offset_px to
  // either side (a localised step, not a lighting gradient), those samples count as on an edge. A wrong camera's
  // line across plain wall or floor averages to no step. Lines whose plain samples are left out (floor, ceiling,
  // texture) are not tested. 0: off (parameter faint_edge_gradient).
  double faint_edge_gradient = 1.0;  // grey levels per px
  double faint_edge_significance = 4.0;
  double faint_edge_beside_ratio = 3.0;
  size_t faint_edge_min_samples = 10;
  // The median held-out residual over the median fitted residual of the matched lines: measured and reported, not
  // enforced (1.1-1.6 for right and wrong results alike on the tuning buildings).
  double max_heldout_ratio = 0.0;
};

struct ImageExplanation
{
  bool image_checked = false;        // there was an image to check against
  size_t map_lines = 0;              // map lines assessed (visible, long enough)
  size_t samples = 0;                // points along them
  size_t plain_lines = 0;            // floor, ceiling, texture lines left out where plain (not in map_lines, samples)
  size_t plain_floor_samples = 0;    // with plain_floor_by_sample: floor and ceiling samples left out (not in samples)
  size_t plain_texture_samples = 0;  // texture lines' samples left out where the image is plain (not in samples)
  double overlay_agreement = 0.0;    // share of the samples on an edge
  double overlay_chance = 0.0;       // share 4 px beside the lines (of the sides not on other map lines)
  // With chance_mapped_radius_px: the points beside the counted samples measured nearer or farther than
  // chance_offset_px (another map line projects there), and those with no place clear of the map lines (left out).
  size_t chance_places_moved = 0, chance_places_none = 0;
  size_t amid_samples = 0;  // no chance place on either side: left out (not in samples)
  // Of the counted samples with no edge beside them on either side (plain surroundings; lines whose plain samples are
  // left out excepted), the share on an edge: texture beside a line does not raise it, as it raises the chance level.
  // A wrong camera's lines on plain wall or floor lower it.
  size_t isolated_samples = 0;
  double isolated_agreement = 0.0;
  size_t faint_samples = 0;  // counted on an edge by the averaged step along their line (faint_edge_gradient)
  double overlayExcess() const
  {
    return overlay_chance < 1.0 ? (overlay_agreement - overlay_chance) / (1.0 - overlay_chance) : 0.0;
  }
  size_t matched_lines = 0;        // lines with a held-out residual
  double median_rms_px = 0.0;      // fitted residual of the matched lines (median over lines)
  double median_heldout_px = 0.0;  // their leave-one-out residual (median over lines)

  std::string describe() const;
};

// Each map line the overlay test assesses, projected and sampled as it samples it, with whether an image edge lies
// under each sample: a run without one is a map edge hidden behind something in front (a foreground object), outside
// the view's structure, or too faint to see.
struct EdgeSamples
{
  std::vector<Eigen::Vector2d> points;      // distorted pixels, in order along the line
  std::vector<Eigen::Vector3d> map_points;  // the map line's points they are the images of (map frame)
  std::vector<bool> on_edge;
  bool counted = true;         // false: a floor or texture line the test left out where the image looks plain
  std::vector<bool> left_out;  // per sample of a counted line: left out there (plain floor or texture); empty: none
  bool countedAt(size_t k) const { return counted && (left_out.empty() || !left_out[k]); }
};

// checked_lines (optional): the lines the overlay test assessed, as EdgeSamples (for the report's overlay: what the
// test saw; its agreement is the share of the counted lines' samples on an edge).
ImageExplanation explainImage(const cv::Mat& image, const CameraModel& camera, int width, int height,
                              const std::vector<Segment3d>& map_lines, const RefinementResult* refinement,
                              const ImageExplanationOptions& options = {},
                              std::vector<EdgeSamples>* checked_lines = nullptr);

// explainImage's checked_lines alone. Lines too short to assess are left out; empty without an image.
std::vector<EdgeSamples> sampleEdgeSupport(const cv::Mat& image, const CameraModel& camera, int width, int height,
                                           const std::vector<Segment3d>& map_lines,
                                           const ImageExplanationOptions& options = {});

// Refuses (kNoSolution, with the numbers and what to do) a camera that fails a test of the options, and one that had
// an image to check against but no map line to assess (all hidden from it behind measured surfaces, out of its view
// or too short: nothing would speak for it).
Status acceptExplanation(const ImageExplanation& explanation, const ImageExplanationOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_IMAGE_EXPLANATION_H
