// The demonstrator scaled down (half the size, four times the frequency, a
// quarter of the time): a 0.35 m square acrylic plate, 2 x 2 foci, the whole
// pipeline in about two seconds. Shared by the calibration tests, which edit
// it with scene_text::replace.
#pragma once

namespace calib_test {

inline const char *const small_scene = R"(
name = "small"
[plate]
size_m = [0.35, 0.35]
thickness_m = 0.002
material = "acrylic"
edges = "clamped"
[plate.loss]
frequencies_hz = [400, 1200]
t60_s = [0.135, 0.045]
[simulation]
points_per_wavelength = 8
precision = "float"
[active_area]
rect_m = [0.05, 0.05, 0.30, 0.30]
frame_margin_m = 0.01
clearance_m = 0.003
[exciters]
count = 8
placement = "random"
seed = 3
min_spacing_m = 0.03
force_full_scale_n = 0.5
restarts = 2
iterations = 300
[foci]
grid = [2, 2]
[pulse]
shape = "hann_burst"
centre_hz = 1200
cycles = 2
amplitude_m = 10e-6
[calibration]
window_s = 0.05
truncate_fraction = 0.3
output_rate_hz = 48000
threshold_m = 5e-6
verify_tail_s = 0.025
)";

}  // namespace calib_test
