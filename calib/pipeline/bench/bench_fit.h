// The bench fit (docs/bench.md): the model's parameters that bring the
// simulated bench responses (bench_model.h) to the measured ones, by
// nonlinear least squares with Ceres Solver (Levenberg-Marquardt with bounds,
// numeric derivatives), their uncertainties from the Jacobian at the
// solution, and which of them the sensors given cannot tell apart.
//
// The cost: for every sensor s and exciter e, the filtered model response
// minus the filtered measured one over the window, each sensor's residuals
// divided by the RMS of its measured responses (so a sensor's quantity or
// units do not weigh it). Three stages, because a speed error of a few per
// cent slips whole periods by the end of a long window (a least-squares fit
// from alpha = 1 would stop in the wrong valley):
//   1. the speed ratio scanned over the model's range at the nominal loss and
//      positions, each pair's gain solved in closed form, on the first
//      third of the window;
//   2. every parameter, on the first half of the window;
//   3. every parameter, on the whole window.
#pragma once
#include "pipeline/bench/bench_model.h"

#include <functional>
#include <string>
#include <vector>

namespace calib::pipeline {

// The measured responses, as the model gives them: measured[s][e], the
// filtered response (BenchModel::band with derivative 0: the sensor already
// measures its quantity) over samples() values, in SI units when the
// sensor's gain is known, else in recorded units.
struct BenchMeasured {
    std::vector<std::vector<std::vector<double>>> responses;
    std::vector<bool> sensor_gain_known; // per sensor
};

struct BenchFitOptions {
    bool speed = true, loss = true, positions = true, gains = true;
    unsigned max_iterations = 40;
    int threads = 0; // 0: all
    std::function<void(const std::string &stage, unsigned done, unsigned total)> progress;
};

struct FitParameter {
    std::string name; // "speed ratio", "loss factor", "exciter 3 x (m)", ...
    double nominal = 0;
    double value = 0;
    double sigma = 0; // one standard deviation from the Jacobian (0 when held)
    bool fitted = false;
    bool identifiable = true;
    std::string note; // why held or not identifiable
};

struct PairFit {
    std::size_t sensor = 0, exciter = 0;
    double before_db = 0, after_db = 0; // residual energy / measured energy over the window
};

struct BenchFitResult {
    BenchParams start, fitted;
    std::vector<FitParameter> parameters;
    std::vector<PairFit> pairs;
    double scanned_speed_ratio = 1;
    double residual_before_db = 0, residual_after_db = 0; // all pairs
    double noise_sigma = 0;                               // the residuals' RMS at the solution (weighted units)
    unsigned iterations = 0;
    std::size_t simulations = 0;
    double seconds = 0;
    std::string solver;             // Ceres's one-line report of the last stage
    std::vector<std::string> notes; // the degeneracies found, in words
};

// Throws std::runtime_error when the solver cannot start (no finite cost).
BenchFitResult fit_bench(const BenchModel &model, const BenchMeasured &measured, const BenchFitOptions &options);

} // namespace calib::pipeline
