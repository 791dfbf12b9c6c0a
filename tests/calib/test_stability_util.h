// Shared set-up of the stability suites (test_stability_*.cpp): the edge sets
// and extreme plates they run, independent bounds on lambda_max, and a
// random state at rest run for many steps.
#pragma once

#include "engine/simulation.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace plate_test {

// Free corners, two free edges meeting, and the three plain edge kinds.
inline const Edges stability_cases[] = {
    Edges::all(EdgeKind::clamped),
    Edges::all(EdgeKind::simply_supported),
    Edges::all(EdgeKind::free),
    {EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported}, // two free edges meet
};

inline double max_abs(const std::vector<double> &u)
{
    double m = 0;
    for (double v : u)
        m = std::max(m, std::abs(v));
    return m;
}

inline std::shared_ptr<PlateOperator> plate_of(double lx, double ly, int nx, int ny, double thickness,
                                               const calib::physics::Material &m, Edges e, Loss loss = {})
{
    PlateParams p;
    p.size_x_m = lx;
    p.size_y_m = ly;
    p.thickness_m = thickness;
    p.material = m;
    p.edges = e;
    p.loss = loss;
    return std::make_shared<PlateOperator>(p, Grid{nx, ny, lx / nx});
}

// Independent bounds on lambda_max(M^-1 K): the Rayleigh quotient of the
// checkerboard (-1)^(i+j) below, the Gershgorin bound of the symmetric-scaled
// rows above. (Measured: with this energy-built operator, free edges do not
// raise lambda_max above the interior 64 kappa^2 / h^4; it is computed anyway.)
inline void expect_bound_between_estimates(const PlateOperator &op, const std::string &what)
{
    const auto &K = op.stiffness();
    const auto &M = op.mass();
    const int w = op.grid().nx + 1;
    Eigen::VectorXd c(op.unknown_count());
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const std::size_t node = op.node_of()[u];
        c[Eigen::Index(u)] = ((node % std::size_t(w) + node / std::size_t(w)) % 2) ? -1.0 : 1.0;
    }
    const double rayleigh = c.dot(K * c) / c.dot(M.cwiseProduct(c));
    double gershgorin = 0;
    for (Eigen::Index r = 0; r < K.rows(); ++r) {
        double row = 0;
        for (PlateOperator::SparseMatrix::InnerIterator it(K, r); it; ++it)
            row += std::abs(it.value()) / std::sqrt(M[r] * M[it.col()]);
        gershgorin = std::max(gershgorin, row);
    }
    const double lambda = op.lambda_max_stiffness();
    EXPECT_GE(lambda, rayleigh * (1 - 1e-12)) << what;
    EXPECT_LE(lambda, gershgorin * (1 + 1e-12)) << what;
}

// Random state at rest, `steps` steps at `fraction` x the bound: relative
// energy change and the field's growth factor.
template <typename T>
std::pair<double, double> run_random_state(std::shared_ptr<const PlateOperator> op, double fraction, std::size_t steps,
                                           unsigned seed)
{
    PlateEngine<T> eng(op, fraction * op->max_time_step());
    eng.set_state(random_field(*op, seed), random_field(*op, seed));
    const double e0 = eng.energy();
    const double u0 = max_abs(eng.displacement());
    double umax = 0, worst = 0;
    ScopedFlushDenormals ftz;
    for (std::size_t n = 1; n <= steps; ++n) {
        eng.step();
        if (n % 200 == 0 || n == steps) {
            umax = std::max(umax, max_abs(eng.displacement()));
            worst = std::max(worst, std::abs(eng.energy() / e0 - 1));
        }
    }
    return {worst, umax / u0};
}

struct Extreme {
    const char *name;
    double lx, ly;
    int nx, ny;
    double thickness;
    calib::physics::Material material;
    Edges edges;
};

inline std::vector<Extreme> extreme_plates()
{
    using calib::physics::material_from_elastic;
    const auto glass = material_from_elastic(2500, 62e9, 0.24, "glass");
    const auto soft = material_from_elastic(1100, 1e6, 0.45, "soft elastomer");   // E ~ 1 MPa
    const auto stiff = material_from_elastic(3510, 1.05e12, 0.1, "diamond-like"); // E ~ 1 TPa
    const Edges two_free{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    const Edges free = Edges::all(EdgeKind::free);
    return {
        {"thin 0.1 mm glass", 0.08, 0.06, 16, 12, 1e-4, glass, two_free},
        {"thick 10 mm glass", 0.4, 0.3, 16, 12, 1e-2, glass, two_free},
        {"soft E = 1 MPa", 0.2, 0.15, 16, 12, 2e-3, soft, two_free},
        {"stiff E = 1 TPa", 0.2, 0.15, 16, 12, 2e-3, stiff, two_free},
        {"aspect 20:1",
         0.4,
         0.02,
         80,
         4,
         2e-3,
         glass,
         {EdgeKind::free, EdgeKind::free, EdgeKind::clamped, EdgeKind::free}},
        {"aspect 1:20 free", 0.02, 0.4, 4, 80, 2e-3, glass, free},
        {"2 x 2 cells free", 0.02, 0.02, 2, 2, 2e-3, glass, free},
        {"3 x 2 cells two free", 0.03, 0.02, 3, 2, 2e-3, glass, two_free},
        {"2 x 3 cells clamped", 0.02, 0.03, 2, 3, 2e-3, glass, Edges::all(EdgeKind::clamped)},
        {"2 x 2 cells simply supported", 0.02, 0.02, 2, 2, 2e-3, glass, Edges::all(EdgeKind::simply_supported)},
    };
}

// The glass plate of the command line: 0.1 x 0.1 x 0.002 m, all free,
// f_max = 2000 Hz at 6 points per (Kirchhoff) wavelength: 6 x 6 cells.
inline std::shared_ptr<PlateOperator> free_glass_plate()
{
    PlateParams p;
    p.size_x_m = 0.1;
    p.size_y_m = 0.1;
    p.thickness_m = 0.002;
    p.material = calib::physics::material_from_elastic(1590, 68.9e9, 0.16, "glass");
    p.edges = Edges::all(EdgeKind::free);
    const double kappa = p.material.kappa(p.thickness_m);
    const double wavelength = 2 * std::numbers::pi * std::sqrt(kappa / (2 * std::numbers::pi * 2000));
    return std::make_shared<PlateOperator>(p, make_grid(0.1, 0.1, wavelength / 6));
}

} // namespace plate_test
