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
// With a DepthAppearance (the world's appearance.depth), before the noise: the rendered depth sampled
// misregistration_px away (bilinear within a surface, nearest across its edges); with noise, a smooth field of sigma
// low_frequency_coefficient z^2 (correlation low_frequency_px) added to z, and flying pixels: a pixel whose
// 4-neighbour is more than flying_step_m + 2 % of z away in depth takes, with probability flying_pixels, a depth
// drawn uniformly between its own and that neighbour's.
// Colour camera optics and processing (CameraAppearance), in the order of a real camera: blur (Gaussian PSF),
// vignetting, exposure and white-balance gains (saturating), then the sensor noise, then JPEG.
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
                           const DepthSensorConfig& config, bool noise, uint64_t seed,
                           const DepthAppearance& appearance = {});

// The rendered depth and surfaces as the depth sensor registers them, shift_px off the colour image.
RenderedView misregisterDepth(const RenderedView& view, const Eigen::Vector2d& shift_px);

// Blur, vignetting and gains of a clean RGB render (deterministic; JPEG is applied per frame by jpegRoundTrip).
cv::Mat applyCameraOptics(const cv::Mat& rgb, const CameraAppearance& appearance, const ViewCamera& camera);

// An RGB image compressed to JPEG at quality 1..100 and decoded.
cv::Mat jpegRoundTrip(const cv::Mat& rgb, int quality);

cv::Mat addImageNoise(const cv::Mat& clean_rgb, const ImageNoiseConfig& noise, uint64_t seed);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_SENSOR_MODELS_H
