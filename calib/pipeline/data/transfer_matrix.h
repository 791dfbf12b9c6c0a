// The plate's transfer matrix H as the stages exchange it (its making and
// its sizes: transfer/transfer.h): the displacement per unit force impulse at
// each exciter, on an observation lattice over the whole plate and at chosen
// points (the foci) exactly, stored decimated in time.
#pragma once
#include "pipeline/data/geometry.h"

#include <cstddef>
#include <vector>

namespace calib::pipeline {

// Every `stride`-th node of the plate grid, row-major from the origin.
struct ObservationLattice {
    int stride = 1;
    int cols = 0, rows = 0; // points per axis
    double spacing_m = 0;
    std::size_t size() const { return std::size_t(cols) * std::size_t(rows); }
    Point at(std::size_t n) const
    {
        return {double(n % std::size_t(cols)) * spacing_m, double(n / std::size_t(cols)) * spacing_m};
    }
};

struct TransferMatrix {
    std::size_t channels = 0;
    std::size_t samples = 0;    // per response
    std::size_t decimation = 1; // simulation steps per stored sample
    double time_step_s = 0;     // of the simulation
    double rate_hz = 0;         // stored rate, 1 / (decimation time_step_s)
    ObservationLattice lattice; // points [0, lattice.size())
    std::vector<Point> points;  // the lattice points, then the exact points (foci)
    std::vector<Point> exciters;
    // data[(c * points.size() + p) * samples + s]: displacement (m) at point p,
    // time s / rate_hz, per N s of force impulse at exciter c.
    std::vector<float> data;

    std::size_t point_count() const { return points.size(); }
    std::size_t exact_begin() const { return lattice.size(); } // first exact point
    const float *response(std::size_t c, std::size_t p) const
    {
        return data.data() + (c * points.size() + p) * samples;
    }
    double bytes() const { return double(channels) * double(points.size()) * double(samples) * sizeof(float); }
};

} // namespace calib::pipeline
