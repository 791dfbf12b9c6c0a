// Shared set-up for the plate tests: plates with round numbers, random
// states, and a scale factor that shortens long runs under the sanitizers.
#pragma once

#include "engine/plate_engine.h"
#include "engine/plate_operator.h"
#include "physics/material.h"

#include <cmath>
#include <memory>
#include <random>
#include <vector>

namespace plate_test {

using namespace calib::engine;

#ifdef HAPTIC_ASAN
constexpr double run_scale = 0.1; // sanitizers are ~10x slower
#else
constexpr double run_scale = 1.0;
#endif

inline std::size_t scaled(double steps) { return std::size_t(std::max(1.0, steps * run_scale)); }

inline calib::physics::Material test_material(double nu = 0.3)
{
    return calib::physics::material_from_elastic(2700.0, 70e9, nu, "test");
}

inline std::shared_ptr<PlateOperator> make_plate(int nx, int ny, double h, Edges edges, double nu = 0.3, Loss loss = {},
                                                 double thickness = 0.002)
{
    PlateParams p;
    p.size_x_m = nx * h;
    p.size_y_m = ny * h;
    p.thickness_m = thickness;
    p.material = test_material(nu);
    p.edges = edges;
    p.loss = loss;
    return std::make_shared<PlateOperator>(p, Grid{nx, ny, h});
}

// A random field on the nodes (fixed nodes are zeroed by set_state).
inline std::vector<double> random_field(const PlateOperator &op, unsigned seed)
{
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> f(op.grid().node_count());
    for (double &v : f)
        v = 1e-6 * u(rng);
    return f;
}

inline std::vector<Edges> all_edge_combinations()
{
    const EdgeKind kinds[3] = {EdgeKind::clamped, EdgeKind::simply_supported, EdgeKind::free};
    std::vector<Edges> out;
    for (EdgeKind l : kinds)
        for (EdgeKind r : kinds)
            for (EdgeKind b : kinds)
                for (EdgeKind t : kinds)
                    out.push_back({l, r, b, t});
    return out;
}

// Every mix of clamped and supported edges (16): the plates with ghost mirrors.
inline std::vector<Edges> mirror_edge_combinations()
{
    std::vector<Edges> out;
    for (int m = 0; m < 16; ++m) {
        auto k = [&](int b) { return (m >> b) & 1 ? EdgeKind::simply_supported : EdgeKind::clamped; };
        out.push_back({k(0), k(1), k(2), k(3)});
    }
    return out;
}

inline std::string describe(const Edges &e)
{
    return std::string("left=") + edge_kind_name(e.left) + " right=" + edge_kind_name(e.right) +
           " bottom=" + edge_kind_name(e.bottom) + " top=" + edge_kind_name(e.top);
}

} // namespace plate_test
