// The bench's responses, simulated (docs/bench.md): what a sensor records when
// one exciter is driven, on the scene's plate with what a real panel varies in
// changed: the speed ratio alpha (kappa / the scene's kappa: the response runs
// alpha times as fast), the loss (the scene's loss law scaled to a loss factor
// eta at the pulse centre), each exciter's position and force gain, and each
// uncalibrated sensor's gain.
//
// How, at the cost of one simulation per sensor and loss value:
// - Reciprocity: one transfer-matrix simulation per sensor (the sensor as the
//   source, pipeline/transfer/transfer.h), recording the grid nodes around
//   each exciter's nominal position. An exciter at p is the bicubic
//   (Catmull-Rom) interpolation of those node responses: smooth in p, so the
//   fit's derivatives are.
// - The speed ratio without a new simulation: on a plate whose kappa is alpha
//   times the scene's (the loss factor kept), the response is
//   H_alpha(t) = H(alpha t) / alpha (robustness/tolerance.h, rescaled_transfer:
//   exact for the scheme when the loss law's sigma0 is 0, as a constant loss
//   factor's is).
// - A loss factor is a new set of simulations, kept in a cache (the fit asks
//   for a few values).
// Responses are compared at the fit rate through one band filter (the fit
// band, and the sensor's time derivative), applied alike to the measured and
// the simulated response over the window and a tail.
#pragma once
#include "pipeline/data/geometry.h"
#include "pipeline/data/input.h"

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace calib::pipeline {

// What a sensor measures: the order of the displacement's time derivative.
enum class SensorQuantity { displacement = 0, velocity = 1, acceleration = 2 };
const char *sensor_quantity_name(SensorQuantity q);

struct BenchSensor {
    Point at;
    SensorQuantity quantity = SensorQuantity::acceleration;
};

struct BenchSetup {
    std::vector<BenchSensor> sensors;
    std::vector<Point> exciters; // nominal positions, as glued
    double force_full_scale_n = 1;
    double radius_m = 0.01;                   // an exciter is sought within this distance of its nominal position
    double f_lo_hz = 0, f_hi_hz = 0;          // the fit band (flat inside, cosine tapers outside)
    double window_s = 0.15;                   // the fitted part of each response
    double speed_min = 0.8, speed_max = 1.25; // the speed ratios the model can take
};

struct BenchParams {
    double speed_ratio = 1; // alpha
    double loss_factor = 0; // eta at the pulse centre
    std::vector<Point> exciters;
    std::vector<double> gains;        // each exciter's force per count / force_full_scale_n
    std::vector<double> sensor_gains; // recorded units per SI unit (1: a calibrated sensor, measured in SI)
};

class BenchModel {
  public:
    // Throws std::invalid_argument for a setup the plate cannot take (a sensor
    // off the plate, a band beyond what the scene's grid resolves).
    BenchModel(const CalibrationInput &in, BenchSetup setup);

    const BenchSetup &setup() const { return setup_; }
    double rate_hz() const { return rate_hz_; }             // the fit rate
    std::size_t samples() const { return window_; }         // fitted samples per response
    std::size_t filtered_samples() const { return total_; } // window and tail, what band() takes
    double nominal_loss_factor() const { return nominal_eta_; }
    BenchParams nominal() const; // the scene's plate: alpha 1, its loss, nominal positions, gains 1

    // The band filter and the sensor's derivative on filtered_samples() samples
    // at the fit rate (a longer x is cut, a shorter padded); returns samples().
    std::vector<double> band(const std::vector<double> &x, int derivative) const;
    // The simulated response of exciter e at sensor s (in the sensor's
    // quantity per unit of normalised drive per second, times the sensor's
    // gain), filtered: samples() values into out.
    void response(const BenchParams &p, std::size_t s, std::size_t e, double *out) const;
    // Simulations run so far (one per sensor and loss value).
    std::size_t simulations() const;

  private:
    struct Traces; // node responses around the exciters for one loss value
    std::shared_ptr<const Traces> traces_at(double eta) const;

    CalibrationInput in_;
    BenchSetup setup_;
    double nominal_eta_ = 0;
    double rate_hz_ = 0;     // fit rate
    double sim_rate_hz_ = 0; // stored rate of the node responses
    std::size_t window_ = 0, total_ = 0, sim_samples_ = 0;
    // Per exciter: the node patch (first node, size) and its points' offset in the recording.
    struct Patch {
        int i0 = 0, j0 = 0, ni = 0, nj = 0;
        std::size_t first = 0;
    };
    std::vector<Patch> patches_;
    std::vector<Point> nodes_;
    mutable std::mutex mutex_, simulating_;
    struct Cached {
        std::shared_ptr<const Traces> traces;
        std::size_t used = 0;
    };
    mutable std::map<double, Cached> cache_;
    mutable std::size_t uses_ = 0;
    mutable std::size_t simulations_ = 0;
};

} // namespace calib::pipeline
