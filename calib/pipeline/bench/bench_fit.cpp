#include "pipeline/bench/bench_fit.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>

namespace calib::pipeline {

namespace {

// The parameter blocks of one fit, laid out for Ceres.
struct Blocks {
    double globals[2] = {1, 0}; // speed ratio, loss factor
    std::vector<std::array<double, 2>> positions;
    std::vector<double> gains;
    std::vector<double> sensor_gains;

    explicit Blocks(const BenchParams &p)
    {
        globals[0] = p.speed_ratio;
        globals[1] = p.loss_factor;
        for (const Point &q : p.exciters)
            positions.push_back({q.x_m, q.y_m});
        gains = p.gains;
        sensor_gains = p.sensor_gains;
    }
    BenchParams params() const
    {
        BenchParams p;
        p.speed_ratio = globals[0];
        p.loss_factor = globals[1];
        for (const auto &q : positions)
            p.exciters.push_back({q[0], q[1]});
        p.gains = gains;
        p.sensor_gains = sensor_gains;
        return p;
    }
};

// The residuals of one (sensor, exciter) pair: parameter blocks globals (2),
// the exciter's position (2), its gain (1), the sensor's gain (1). Jacobians
// by central differences with a step per parameter chosen for the model's
// resolution (a loss step of 1 % of the loss factor: its effect over the
// window must stand well above the float-stored node responses' rounding).
class PairCost final : public ceres::CostFunction {
  public:
    PairCost(const BenchModel &model, const BenchParams &base, const std::vector<double> &measured, double weight,
             std::size_t s, std::size_t e, std::size_t n)
        : model_(model), base_(base), measured_(measured), weight_(weight), s_(s), e_(e), n_(n)
    {
        set_num_residuals(int(n));
        mutable_parameter_block_sizes()->assign({2, 2, 1, 1});
    }

    bool Evaluate(double const *const *x, double *residuals, double **jacobians) const override
    {
        std::vector<double> out(model_.samples());
        auto eval = [&](const double *g, const double *pos, double gain, double sgain, double *r) {
            BenchParams p = base_;
            p.speed_ratio = g[0];
            p.loss_factor = g[1];
            p.exciters[e_] = {pos[0], pos[1]};
            p.gains[e_] = gain;
            p.sensor_gains[s_] = sgain;
            model_.response(p, s_, e_, out.data());
            for (std::size_t i = 0; i < n_; i++)
                r[i] = weight_ * (out[i] - measured_[i]);
        };
        try {
            eval(x[0], x[1], x[2][0], x[3][0], residuals);
            if (!jacobians)
                return true;
            std::vector<double> rp(n_), rm(n_);
            const double steps[6] = {1e-4, std::max(1e-6, 0.01 * std::abs(x[0][1])), 2e-4, 2e-4, 1e-3, 1e-3};
            int k = 0;
            for (int b = 0; b < 4; b++) {
                const int size = b < 2 ? 2 : 1;
                for (int c = 0; c < size; c++, k++) {
                    if (!jacobians[b])
                        continue;
                    double g[2] = {x[0][0], x[0][1]}, pos[2] = {x[1][0], x[1][1]};
                    double gain = x[2][0], sgain = x[3][0];
                    double *v = b == 0 ? &g[c] : b == 1 ? &pos[c] : b == 2 ? &gain : &sgain;
                    const double h = steps[k], v0 = *v;
                    *v = v0 + h;
                    eval(g, pos, gain, sgain, rp.data());
                    *v = v0 - h;
                    eval(g, pos, gain, sgain, rm.data());
                    for (std::size_t i = 0; i < n_; i++)
                        jacobians[b][i * std::size_t(size) + std::size_t(c)] = (rp[i] - rm[i]) / (2 * h);
                }
            }
            return true;
        } catch (const std::exception &) {
            return false; // a plate the model cannot take: Ceres shrinks its step
        }
    }

  private:
    const BenchModel &model_;
    const BenchParams &base_;
    const std::vector<double> &measured_;
    double weight_;
    std::size_t s_, e_, n_;
};

double energy(const std::vector<double> &x, std::size_t n)
{
    double e = 0;
    for (std::size_t i = 0; i < n && i < x.size(); i++)
        e += x[i] * x[i];
    return e;
}

double db(double ratio) { return ratio > 0 ? 10 * std::log10(ratio) : -300.0; }

} // namespace

BenchFitResult fit_bench(const BenchModel &model, const BenchMeasured &measured, const BenchFitOptions &options)
{
    const auto t0 = std::chrono::steady_clock::now();
    const BenchSetup &setup = model.setup();
    const std::size_t S = setup.sensors.size(), E = setup.exciters.size(), N = model.samples();
    if (measured.responses.size() != S || measured.sensor_gain_known.size() != S)
        throw std::invalid_argument("bench fit: measured responses do not match the sensors");
    bool any_known = false;
    for (bool k : measured.sensor_gain_known)
        any_known = any_known || k;
    // Each sensor weighs alike: its residuals over the RMS of its measured responses.
    std::vector<double> weight(S);
    for (std::size_t s = 0; s < S; s++) {
        double e = 0;
        for (std::size_t c = 0; c < E; c++)
            e += energy(measured.responses[s][c], N);
        if (!(e > 0))
            throw std::invalid_argument("bench fit: sensor " + std::to_string(s) + " measured nothing in the band");
        weight[s] = 1 / std::sqrt(e / double(E * N));
    }
    auto progress = [&](const std::string &stage, unsigned done, unsigned total) {
        if (options.progress)
            options.progress(stage, done, total);
    };

    BenchFitResult r;
    BenchParams p = model.nominal();
    r.start = p;
    std::vector<double> m(N);

    // Stage 1: the speed ratio by a scan; each pair's gain in closed form.
    const std::size_t n1 = std::max<std::size_t>(16, N / 3);
    auto scan_cost = [&](double alpha, std::vector<double> *pair_gain) {
        BenchParams q = p;
        q.speed_ratio = alpha;
        double cost = 0;
        for (std::size_t s = 0; s < S; s++)
            for (std::size_t e = 0; e < E; e++) {
                model.response(q, s, e, m.data());
                const std::vector<double> &y = measured.responses[s][e];
                double my = 0, mm = 0, yy = 0;
                for (std::size_t i = 0; i < n1; i++)
                    my += m[i] * y[i], mm += m[i] * m[i], yy += y[i] * y[i];
                const double g = mm > 0 ? my / mm : 0;
                cost += weight[s] * weight[s] * (yy - g * my);
                if (pair_gain)
                    (*pair_gain)[s * E + e] = g;
            }
        return cost;
    };
    if (options.speed) {
        const double span = setup.speed_max - setup.speed_min;
        const double step = 0.1 / (setup.f_hi_hz * double(n1) / model.rate_hz());
        const auto count = static_cast<unsigned>(std::ceil(span / step)) + 1;
        double best = INFINITY, best_alpha = 1;
        for (unsigned i = 0; i < count; i++) {
            const double a = setup.speed_min + span * double(i) / double(count - 1);
            const double c = scan_cost(a, nullptr);
            if (c < best)
                best = c, best_alpha = a;
            progress("fit: speed scan", i + 1, count);
        }
        // A finer scan around the best.
        const double fine = span / double(count - 1);
        for (int i = -10; i <= 10; i++) {
            const double a = std::clamp(best_alpha + fine * i / 10.0, setup.speed_min, setup.speed_max);
            const double c = scan_cost(a, nullptr);
            if (c < best)
                best = c, best_alpha = a;
        }
        p.speed_ratio = best_alpha;
    }
    r.scanned_speed_ratio = p.speed_ratio;
    // Start values of the gains: per exciter the mean of its pairs' closed-form
    // gains over the sensors of known gain (or all, relative to exciter 1).
    {
        std::vector<double> g(S * E, 0.0);
        scan_cost(p.speed_ratio, &g);
        for (std::size_t s = 0; s < S; s++)
            if (!measured.sensor_gain_known[s]) {
                double sum = 0;
                for (std::size_t e = 0; e < E; e++)
                    sum += g[s * E + e];
                p.sensor_gains[s] = std::max(1e-30, std::abs(sum / double(E)));
            }
        for (std::size_t e = 0; e < E && options.gains; e++) {
            double sum = 0;
            unsigned n = 0;
            for (std::size_t s = 0; s < S; s++)
                if (measured.sensor_gain_known[s] || !any_known) {
                    sum += g[s * E + e] / (measured.sensor_gain_known[s] ? 1.0 : p.sensor_gains[s]);
                    n++;
                }
            if (n > 0 && sum > 0)
                p.gains[e] = sum / n;
        }
        if (!any_known && options.gains) { // relative to exciter 1, which is held
            const double g0 = p.gains[0];
            for (double &v : p.gains)
                v /= g0;
            for (double &v : p.sensor_gains)
                v *= g0;
        }
    }

    // Stages 2 and 3: every parameter by Levenberg-Marquardt.
    Blocks b(p);
    auto solve = [&](std::size_t n, const std::string &stage) {
        ceres::Problem::Options po;
        po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
        ceres::Problem problem(po);
        const BenchParams base = b.params();
        for (std::size_t s = 0; s < S; s++)
            for (std::size_t e = 0; e < E; e++)
                problem.AddResidualBlock(new PairCost(model, base, measured.responses[s][e], weight[s], s, e, n),
                                         nullptr, b.globals, b.positions[e].data(), &b.gains[e], &b.sensor_gains[s]);
        problem.SetParameterLowerBound(b.globals, 0, setup.speed_min);
        problem.SetParameterUpperBound(b.globals, 0, setup.speed_max);
        const double eta0 = model.nominal_loss_factor();
        if (options.loss && eta0 > 0) {
            problem.SetParameterLowerBound(b.globals, 1, 0.2 * eta0);
            problem.SetParameterUpperBound(b.globals, 1, 5 * eta0);
        }
        std::vector<int> held;
        if (!options.speed)
            held.push_back(0);
        if (!options.loss || eta0 <= 0)
            held.push_back(1);
        if (held.size() == 2)
            problem.SetParameterBlockConstant(b.globals);
        else if (!held.empty())
            problem.SetManifold(b.globals, new ceres::SubsetManifold(2, held));
        for (std::size_t e = 0; e < E; e++) {
            if (options.positions)
                for (int c = 0; c < 2; c++) {
                    const double v0 = c == 0 ? setup.exciters[e].x_m : setup.exciters[e].y_m;
                    problem.SetParameterLowerBound(b.positions[e].data(), c, v0 - setup.radius_m);
                    problem.SetParameterUpperBound(b.positions[e].data(), c, v0 + setup.radius_m);
                }
            else
                problem.SetParameterBlockConstant(b.positions[e].data());
            if (!options.gains || (!any_known && e == 0))
                problem.SetParameterBlockConstant(&b.gains[e]);
            else
                problem.SetParameterLowerBound(&b.gains[e], 0, 1e-3);
        }
        for (std::size_t s = 0; s < S; s++)
            if (measured.sensor_gain_known[s])
                problem.SetParameterBlockConstant(&b.sensor_gains[s]);
        ceres::Solver::Options so;
        so.linear_solver_type = ceres::DENSE_QR;
        so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
        so.max_num_iterations = int(options.max_iterations);
        so.num_threads = options.threads > 0 ? options.threads : int(std::max(1u, std::thread::hardware_concurrency()));
        so.logging_type = ceres::SILENT;
        so.minimizer_progress_to_stdout = false;
        so.function_tolerance = 1e-6;
        so.parameter_tolerance = 1e-7;
        struct Callback final : ceres::IterationCallback {
            std::function<void(unsigned)> f;
            ceres::CallbackReturnType operator()(const ceres::IterationSummary &it) override
            {
                f(unsigned(it.iteration));
                return ceres::SOLVER_CONTINUE;
            }
        } cb;
        cb.f = [&](unsigned it) { progress(stage, it, options.max_iterations); };
        so.callbacks.push_back(&cb);
        ceres::Solver::Summary summary;
        ceres::Solve(so, &problem, &summary);
        r.iterations += unsigned(summary.iterations.size());
        r.solver = summary.BriefReport();
        if (summary.termination_type == ceres::FAILURE)
            throw std::runtime_error("bench fit: the solver failed (" + summary.message + ")");
    };
    solve(std::max<std::size_t>(16, N / 2), "fit: first half");
    solve(N, "fit: whole window");
    p = b.params();
    if (!any_known && options.gains) { // report gains relative to their mean, which the sensors cannot see
        double mean = 0;
        for (double v : p.gains)
            mean += v / double(E);
        for (double &v : p.gains)
            v /= mean;
        for (double &v : p.sensor_gains)
            v *= mean;
        b = Blocks(p);
    }
    r.fitted = p;

    // Residuals before and after, per pair and in all.
    double before = 0, after = 0, total = 0;
    std::vector<double> m0(N), m1(N);
    for (std::size_t s = 0; s < S; s++)
        for (std::size_t e = 0; e < E; e++) {
            BenchParams q = r.start;
            for (std::size_t c = 0; c < S; c++) // the start's unknown sensor gains at their first estimate
                if (!measured.sensor_gain_known[c])
                    q.sensor_gains[c] = p.sensor_gains[c];
            model.response(q, s, e, m0.data());
            model.response(p, s, e, m1.data());
            const std::vector<double> &y = measured.responses[s][e];
            double e0 = 0, e1 = 0, ey = 0;
            for (std::size_t i = 0; i < N; i++) {
                e0 += (m0[i] - y[i]) * (m0[i] - y[i]);
                e1 += (m1[i] - y[i]) * (m1[i] - y[i]);
                ey += y[i] * y[i];
            }
            r.pairs.push_back({s, e, db(e0 / ey), db(e1 / ey)});
            const double w2 = weight[s] * weight[s];
            before += w2 * e0, after += w2 * e1, total += w2 * ey;
        }
    r.residual_before_db = db(before / total);
    r.residual_after_db = db(after / total);

    // Uncertainties: the Jacobian of the weighted residuals at the solution
    // (the same central differences), sigma^2 (J^T J)^-1 with sigma^2 the
    // residuals' variance; directions the Jacobian does not see are named.
    struct Column {
        std::string name;
        double nominal, value;
        bool fitted;
        std::string note;
    };
    std::vector<Column> cols;
    const double eta0 = model.nominal_loss_factor();
    cols.push_back({"speed ratio", 1.0, p.speed_ratio, options.speed, options.speed ? "" : "held (not asked)"});
    cols.push_back({"loss factor", eta0, p.loss_factor, options.loss && eta0 > 0,
                    eta0 > 0 ? (options.loss ? "" : "held (not asked)") : "the scene's plate has no loss"});
    for (std::size_t e = 0; e < E; e++)
        for (int c = 0; c < 2; c++)
            cols.push_back({"exciter " + std::to_string(e + 1) + (c ? " y (m)" : " x (m)"),
                            c ? setup.exciters[e].y_m : setup.exciters[e].x_m,
                            c ? p.exciters[e].y_m : p.exciters[e].x_m, options.positions,
                            options.positions ? "" : "held (not asked)"});
    for (std::size_t e = 0; e < E; e++)
        cols.push_back({"exciter " + std::to_string(e + 1) + " force gain", 1.0, p.gains[e],
                        options.gains && (any_known || e > 0),
                        !options.gains           ? "held (not asked)"
                        : (!any_known && e == 0) ? "no sensor of known gain: the gains are relative (mean 1)"
                                                 : ""});
    for (std::size_t s = 0; s < S; s++)
        cols.push_back({"sensor " + std::to_string(s + 1) + " gain", 1.0, p.sensor_gains[s],
                        !measured.sensor_gain_known[s],
                        measured.sensor_gain_known[s] ? "known (units_per_count)" : ""});
    std::vector<int> fitted_cols;
    for (std::size_t c = 0; c < cols.size(); c++)
        if (cols[c].fitted)
            fitted_cols.push_back(int(c));
    const std::size_t rows = S * E * N, P = fitted_cols.size();
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(Eigen::Index(rows), Eigen::Index(P));
    Eigen::VectorXd res = Eigen::VectorXd::Zero(Eigen::Index(rows));
    {
        // Column index of each block's entries in `cols`.
        auto col_of = [&](std::size_t s, std::size_t e, int block, int c) -> int {
            if (block == 0)
                return c;
            if (block == 1)
                return int(2 + 2 * e) + c;
            if (block == 2)
                return int(2 + 2 * E + e);
            return int(2 + 3 * E + s);
        };
        std::vector<int> where(cols.size(), -1);
        for (std::size_t k = 0; k < P; k++)
            where[std::size_t(fitted_cols[k])] = int(k);
        for (std::size_t s = 0; s < S; s++)
            for (std::size_t e = 0; e < E; e++) {
                PairCost cost(model, p, measured.responses[s][e], weight[s], s, e, N);
                double g[2] = {p.speed_ratio, p.loss_factor}, pos[2] = {p.exciters[e].x_m, p.exciters[e].y_m};
                double gain = p.gains[e], sgain = p.sensor_gains[s];
                const double *x[4] = {g, pos, &gain, &sgain};
                std::vector<double> jb[4] = {std::vector<double>(N * 2), std::vector<double>(N * 2),
                                             std::vector<double>(N), std::vector<double>(N)};
                double *jp[4] = {jb[0].data(), jb[1].data(), jb[2].data(), jb[3].data()};
                std::vector<double> rr(N);
                cost.Evaluate(x, rr.data(), jp);
                const std::size_t row0 = (s * E + e) * N;
                for (std::size_t i = 0; i < N; i++) {
                    res[Eigen::Index(row0 + i)] = rr[i];
                    for (int bl = 0; bl < 4; bl++) {
                        const int size = bl < 2 ? 2 : 1;
                        for (int c = 0; c < size; c++) {
                            const int w = where[std::size_t(col_of(s, e, bl, c))];
                            if (w >= 0)
                                J(Eigen::Index(row0 + i), w) = jb[bl][i * std::size_t(size) + std::size_t(c)];
                        }
                    }
                }
            }
    }
    const double dof = double(rows) - double(P);
    const double sigma2 = dof > 0 ? res.squaredNorm() / dof : 0;
    r.noise_sigma = std::sqrt(sigma2);
    std::vector<double> sigma(cols.size(), 0.0);
    std::vector<bool> identifiable(cols.size(), true);
    if (P > 0) {
        Eigen::VectorXd scale = Eigen::VectorXd::Zero(Eigen::Index(P));
        for (Eigen::Index k = 0; k < Eigen::Index(P); k++) {
            const double n = J.col(k).norm();
            scale[k] = n > 0 ? 1 / n : 0;
        }
        const Eigen::MatrixXd Js = J * scale.asDiagonal();
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Js.transpose() * Js);
        const Eigen::VectorXd lam = eig.eigenvalues();
        const double lmax = lam.maxCoeff();
        Eigen::MatrixXd inv = Eigen::MatrixXd::Zero(Eigen::Index(P), Eigen::Index(P));
        for (Eigen::Index i = 0; i < Eigen::Index(P); i++) {
            const Eigen::VectorXd v = eig.eigenvectors().col(i);
            if (lam[i] > 1e-10 * lmax) {
                inv += v * v.transpose() / lam[i];
                continue;
            }
            // A direction the sensors do not see: the parameters it moves.
            std::string names;
            for (Eigen::Index k = 0; k < Eigen::Index(P); k++)
                if (std::abs(v[k]) > 0.3) {
                    identifiable[std::size_t(fitted_cols[std::size_t(k)])] = false;
                    names += (names.empty() ? "" : ", ") + cols[std::size_t(fitted_cols[std::size_t(k)])].name;
                }
            r.notes.push_back("not identifiable from these sensors (they change the responses only together): " +
                              names);
        }
        for (Eigen::Index k = 0; k < Eigen::Index(P); k++)
            sigma[std::size_t(fitted_cols[std::size_t(k)])] = std::sqrt(sigma2 * inv(k, k)) * scale[k];
    }
    for (std::size_t c = 0; c < cols.size(); c++)
        r.parameters.push_back(
            {cols[c].name, cols[c].nominal, cols[c].value, sigma[c], cols[c].fitted, identifiable[c], cols[c].note});
    if (any_known)
        r.notes.push_back("the plate's mass per area enters the responses only as the ratio of the exciters' force "
                          "gains to it: the fitted force gains include it (E follows from the speed ratio as "
                          "E = alpha^2 E_scene for the scene's density and thickness)");
    r.simulations = model.simulations();
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

} // namespace calib::pipeline
