// Band-limited resampling with soxr (high quality, linear phase): how every
// signal of the pipeline changes rate (recordings to the search rate, drives
// to the device rate and back to a simulation's).
#pragma once
#include <cstddef>
#include <vector>

namespace calib::pipeline {

// One signal from in_rate_hz to out_rate_hz.
std::vector<double> resample(const std::vector<double> &x, double in_rate_hz, double out_rate_hz);
// The same for signals of one length, through one filter design per group of
// resample_group_channels: each output equals resample() of its input.
constexpr std::size_t resample_group_channels = 32;
std::vector<std::vector<double>> resample_all(const std::vector<std::vector<double>> &x, double in_rate_hz,
                                              double out_rate_hz);

} // namespace calib::pipeline
