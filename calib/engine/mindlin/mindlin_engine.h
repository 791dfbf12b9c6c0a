// Leapfrog time stepping of a MindlinOperator (double precision): the engine
// of the thick plate, beside the Kirchhoff PlateEngine. It offers what
// Simulation::run asks of every engine (sources, receivers, step, energy,
// the displacement field, a non-finite scan) and the point interface of the
// effect extensions (point_field.h), so the finger and the exciter serve both.
//
// Step: q+ = 2 q - q- - k^2 M^-1 K q (fused CSR rows, a compiled loop), then
// the sources and the extensions act on w at their points.
#pragma once

#include "engine/mindlin/mindlin_operator.h"
#include "engine/point_field.h"

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace calib::engine::mindlin {

class MindlinEngine final : public PointField {
  public:
    using value_type = double;

    // Throws std::invalid_argument if time_step_s is not below the bound.
    MindlinEngine(std::shared_ptr<const MindlinOperator> op, double time_step_s);

    const MindlinOperator &plate() const { return *op_; }
    double time_step() const override { return k_; }
    std::size_t steps_done() const { return steps_; }
    // Whether step() runs its rows on an OpenMP team.
    bool threaded() const;

    std::size_t add_source(double x_m, double y_m);   // point force on w, bilinear
    std::size_t add_receiver(double x_m, double y_m); // w, same weights
    void set_source_force(std::size_t s, double force_n) { sources_[s].force = force_n; }
    double receiver_value(std::size_t r) const;

    void add_extension(std::unique_ptr<PointExtension> ext) { extensions_.push_back(std::move(ext)); }
    // The point interface (point_field.h): w's unknowns, mass-scaled gains.
    double lambda_max() const override { return op_->lambda_max(); }
    PointTaps couple(double x_m, double y_m, const char *effect) const override;
    PointLevels read(const PointTaps &point) const override;
    void apply(const PointTaps &point, double force_n) override;

    void step();
    double energy() const; // J, at n+1/2 (the plate's; a finger's own energy is not included)

    // w on the node grid, row-major (j, i), 0 at held nodes.
    std::vector<double> displacement() const;
    double w_at(int i, int j) const;
    // Empty while every unknown is finite; else what and where (the first
    // non-finite w node, else the first rotation) and how many.
    std::string non_finite_report() const;

    // Unknown vectors (layout of MindlinOperator) for q^n and q^{n-1}.
    const Eigen::VectorXd &state() const { return cur_; }
    void set_state(const Eigen::VectorXd &current, const Eigen::VectorXd &previous);

  private:
    struct Tap {
        std::vector<Eigen::Index> index;
        std::vector<double> weight;
        double force = 0;
    };
    Tap tap_at(double x_m, double y_m, bool scale_by_mass) const;

    std::shared_ptr<const MindlinOperator> op_;
    double k_ = 0;
    std::size_t steps_ = 0;
    MindlinOperator::SparseMatrix update_; // k^2 M^-1 K
    Eigen::VectorXd prev_, cur_, next_;
    std::vector<Tap> sources_, receivers_;
    std::vector<std::unique_ptr<PointExtension>> extensions_;
};

} // namespace calib::engine::mindlin
