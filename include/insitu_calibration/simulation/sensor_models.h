// Sensor models applied to rendered views.
//
// Xtion registered depth (16UC1, millimetres, 0 = no return):
//   - no return where nothing is seen, beyond max_range or nearer than min_range (both on z), and where the ray meets
//     the surface more obliquely than max_incidence_deg;
//   - axial noise: z + N(0, (c_g z^2)^2), then the disparity d = f b / z quantised to 1/subpixel px, then z = f b / d.
//     c_g is chosen so that the Gaussian and the quantisation together have sigma_coefficient * z^2 (the common
//     1.4e-3 z^2 model for this sensor); with correlation_px > 0 the Gaussian field is smooth over that many pixels
//     (the sensor's correlation window), with the same sigma at every pixel;
//   - rounding to whole millimetres.
//   Without noise only the rounding to millimetres remains (and the no-return rules).
// Colour sensor noise (fixed cameras, and the Xtion RGB when its sigma is set): per channel
//   I + N(0, read^2 + gain I), rounded and clamped to 0..255.
#ifndef INSITU_CALIBRATION_SIMULATION_SENSOR_MODELS_H
#define INSITU_CALIBRATION_SIMULATION_SENSOR_MODELS_H

#include <cstdint>

#include <opencv2/core.hpp>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
// Standard deviation of the Gaussian part, per z^2 (see above); 0 when the quantisation alone exceeds the total.
double depthGaussianCoefficient(const DepthSensorConfig& config, double focal_px);

cv::Mat simulateXtionDepth(const RenderedView& view, const World& world, const ViewCamera& camera,
                           const DepthSensorConfig& config, bool noise, uint64_t seed);

cv::Mat addImageNoise(const cv::Mat& clean_rgb, const ImageNoiseConfig& noise, uint64_t seed);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_SENSOR_MODELS_H
