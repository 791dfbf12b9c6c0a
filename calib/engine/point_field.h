// What a point effect (finger, exciter; engine/effects/) needs of an engine,
// whichever plate model it steps (the Kirchhoff PlateEngine, the Mindlin
// engine): the plate displacement W = phi^T w at one point, read at the three
// time levels of a leapfrog step, and a force at that point spread back onto
// the plate. phi are the receiver's bilinear weights; gain_n = phi_n times the
// displacement one newton during one step gives node n, so
// g = sum phi_n gain_n is the displacement per newton at the point: what makes
// the coupled scalar equation of each effect solvable exactly, once per step.
//
// An engine calls its extensions once per step, after its own update (bulk,
// edges, sources): W^{n+1} is then the field without the extension's force,
// which apply() adds. These are a few virtual calls per extension and step;
// the bulk loops stay compiled kernels of each engine.
#pragma once

#include <array>
#include <cstddef>

namespace calib::engine {

// Up to four nodes of the field (bilinear weights; held nodes left out).
struct PointTaps {
    std::size_t count = 0;
    std::array<std::ptrdiff_t, 4> index{}; // where the engine keeps each node's w
    std::array<double, 4> weight{};        // phi
    std::array<double, 4> gain{};          // phi * displacement per newton of one step
    double g = 0;                          // sum weight * gain
};

// W at step n+1 (before the extension's force), n and n-1.
struct PointLevels {
    double next = 0, now = 0, prev = 0;
};

class PointField {
  public:
    virtual double time_step() const = 0;
    // Largest eigenvalue of M^-1 K of the plate: an explicit spring added at a
    // point must fit in the margin 1 - k^2 lambda / 4 the time step leaves.
    virtual double lambda_max() const = 0;
    // Throws std::invalid_argument off the plate, or (naming `effect`) on
    // held nodes only.
    virtual PointTaps couple(double x_m, double y_m, const char *effect) const = 0;
    virtual PointLevels read(const PointTaps &point) const = 0;
    // Adds the displacement a force (N) applied during this step causes.
    virtual void apply(const PointTaps &point, double force_n) = 0;

  protected:
    ~PointField() = default;
};

// An effect with a state of its own, called by the engine once per step.
class PointExtension {
  public:
    virtual ~PointExtension() = default;
    virtual void after_update(PointField &field) = 0;
};

} // namespace calib::engine
