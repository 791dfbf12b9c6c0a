// A small lossy acrylic plate (the demonstrator scaled down), two fixed
// exciters, two foci, double precision: the transfer-matrix and robustness
// tests run on it.
#pragma once

inline const char *small_lossy_scene = R"(
name = "transfer"
[plate]
size_m = [0.30, 0.24]
thickness_m = 0.002
material = "acrylic"
edges = "clamped"
[plate.loss]
frequencies_hz = [400, 1200]
t60_s = [0.135, 0.045]
[simulation]
points_per_wavelength = 8
precision = "double"
[active_area]
rect_m = [0.05, 0.05, 0.25, 0.19]
frame_margin_m = 0.01
clearance_m = 0.003
[exciters]
count = 2
placement = "fixed"
positions_m = [[0.021, 0.033], [0.273, 0.205]]
force_full_scale_n = 0.5
[foci]
points_m = [[0.1, 0.1], [0.2, 0.14]]
[pulse]
shape = "hann_burst"
centre_hz = 1200
cycles = 2
amplitude_m = 10e-6
[calibration]
window_s = 0.04
truncate_fraction = 0.3
output_rate_hz = 48000
threshold_m = 5e-6
verify_tail_s = 0.01
)";
