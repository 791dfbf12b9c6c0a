// `calibgen simulate SCENE.toml --source X,Y --record X,Y ... --duration S -o traces.csv`:
// one impulse response (a unit force impulse, 1 N s, at the source) with the
// displacement at each receiver, for inspection and checks.
#include "app/commands.h"
#include "io/atomic_file.h"

#include "engine/simulation.h"
#include "model/resources.h"
#include "scene/scene.h"
#include "scene/toml_fields.h"

#include <chrono>
#include <cstdio>
#include <ostream>
#include <unistd.h>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

struct Point {
    double x, y;
};

Point parse_point(const std::string &option, const std::string &text)
{
    const auto comma = text.find(',');
    try {
        if (comma == std::string::npos)
            throw std::invalid_argument("");
        std::size_t used_x = 0, used_y = 0;
        const std::string xs = text.substr(0, comma), ys = text.substr(comma + 1);
        const double x = std::stod(xs, &used_x), y = std::stod(ys, &used_y);
        if (used_x != xs.size() || used_y != ys.size())
            throw std::invalid_argument("");
        return {x, y};
    } catch (const std::exception &) {
        throw std::invalid_argument(option + " " + text + ": expected X,Y in metres (e.g. 0.25,0.1)");
    }
}

struct SimulateArgs {
    std::string scene;
    std::string source;
    std::vector<std::string> records;
    double duration_s = 0;
    std::string output;
    std::string precision;
    int threads = -1;
    std::optional<double> max_memory_mb, max_seconds;
};

int run_simulate(const SimulateArgs &a)
{
    scene::Scene sc = scene::load_scene(a.scene);
    if (!a.precision.empty())
        sc.simulation.precision = a.precision == "double" ? engine::Precision::f64 : engine::Precision::f32;
    if (a.threads >= 0)
        sc.simulation.threads = a.threads;
    const Point src = parse_point("--source", a.source);
    std::vector<Point> recs;
    for (const std::string &r : a.records)
        recs.push_back(parse_point("--record", r));
    if (!(a.duration_s > 0))
        throw std::invalid_argument("--duration: must be > 0 seconds");

    model::refuse_before_build(sc, model::machine_limits(a.max_memory_mb, a.max_seconds), false, a.duration_s,
                               recs.size());
    scene::PlateSetup setup = scene::build_plate(sc);
    engine::Simulation sim(setup.plate, setup.options);
    auto at = [&](const char *what, Point p, auto add) {
        try {
            return add(p.x, p.y);
        } catch (const std::invalid_argument &e) {
            throw std::invalid_argument(std::string(what) + ": " + e.what());
        }
    };
    const std::size_t s = at("--source", src, [&](double x, double y) { return sim.add_source(x, y); });
    for (const Point &p : recs)
        at("--record", p, [&](double x, double y) { return sim.add_receiver(x, y); });
    sim.set_source_impulse(s);

    const engine::Grid &g = setup.plate->grid();
    const std::size_t steps = sim.steps_for(a.duration_s);
    // Fail before a long run if the output cannot be written at all.
    const std::filesystem::path dir = std::filesystem::absolute(a.output).parent_path();
    if (::access(dir.c_str(), W_OK) != 0)
        throw std::runtime_error(a.output + ": cannot write (directory " + dir.string() + ")");
    const auto t0 = std::chrono::steady_clock::now();
    sim.run(steps);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    // Written next to the target and renamed: never a half-written file.
    io::write_stream_atomic(a.output, [&](std::ostream &out) {
        char buf[32];
        out << "time_s";
        for (const Point &p : recs)
            out << ",u_at_" << p.x << "_" << p.y << "_m";
        out << "\n";
        const auto &tr = sim.traces();
        for (std::size_t n = 0; n < steps; ++n) {
            std::snprintf(buf, sizeof buf, "%.9e", double(n + 1) * sim.time_step_s());
            out << buf;
            for (const auto &t : tr) {
                std::snprintf(buf, sizeof buf, ",%.9e", t[n]);
                out << buf;
            }
            out << "\n";
        }
    });
    // Reported after the run, so a failure is the one line on stderr.
    std::fprintf(stderr,
                 "simulate: %d x %d intervals, h = %.4g m, plate %.4g x %.4g m, k = %.4g s (bound %.4g s), %zu steps, "
                 "%s\n",
                 g.nx, g.ny, g.h, g.length_x_m(), g.length_y_m(), sim.time_step_s(), setup.plate->max_time_step(),
                 steps, engine::precision_name(sim.precision()));
    std::fprintf(stderr, "simulate: %.3f s wall, %.3g node updates/s\n", wall,
                 double(steps) * double(g.node_count()) / std::max(wall, 1e-9));
    return 0;
}

} // namespace

void register_simulate(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<SimulateArgs>();
    CLI::App *cmd = app.add_subcommand("simulate", "Impulse response of a scene's plate: receiver traces as CSV");
    cmd->add_option("scene", a->scene, "Scene file (.toml)")->required();
    cmd->add_option("--source", a->source, "Source point X,Y (m); a unit force impulse (1 N s) at t = 0")->required();
    cmd->add_option("--record", a->records, "Receiver point X,Y (m); repeat for more")->required();
    cmd->add_option("--duration", a->duration_s, "Simulated time (s)")->required();
    cmd->add_option("-o,--output", a->output, "Output CSV: time_s + one displacement column (m) per receiver")
        ->required();
    cmd->add_option("--precision", a->precision, "Override the scene: float or double")
        ->check(CLI::IsMember({"float", "double"}));
    cmd->add_option("--threads", a->threads, "Override the scene: OpenMP threads (0: all)");
    cmd->add_option("--max-memory", a->max_memory_mb,
                    "Refuse (before simulating) a run predicted to need more than this many MB (default: physical "
                    "memory)");
    cmd->add_option("--max-seconds", a->max_seconds,
                    "Refuse (before simulating) a run predicted to take longer than this (default: no limit)");
    cmd->callback([a, &exit_code] {
        try {
            exit_code = run_simulate(*a);
        } catch (const std::exception &e) {
            std::fprintf(stderr, "calibgen simulate: %s\n", e.what());
            exit_code = 1;
        }
    });
}

} // namespace calib::app
