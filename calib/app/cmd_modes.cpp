// `calibgen modes SCENE --count N -o modes.csv [--png DIR]`: the plate's
// lowest eigenmodes (engine/modes.h) on the scene's grid, as a CSV of
// frequencies and, with --png, one image per mode shape.
#include "app/commands.h"
#include "engine/modes.h"
#include "physics/dispersion.h"
#include "io/atomic_file.h"
#include "io/format.h"
#include "model/resources.h"
#include "report/image.h"
#include "report/mode_image.h"
#include "scene/scene.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

struct ModesArgs {
    std::string scene;
    int count = 0;
    std::string output;
    std::string png_dir;
    std::optional<double> max_memory_mb;
};

void write_mode_png(const std::string &path, const std::vector<double> &field, int nodes_x, int nodes_y)
{
    const std::vector<std::uint8_t> bytes = report::encode_png(report::mode_shape_image(field, nodes_x, nodes_y));
    io::write_file_atomic(path, std::string_view(reinterpret_cast<const char *>(bytes.data()), bytes.size()));
}

void require_writable_dir(const std::string &what, const std::filesystem::path &dir)
{
    if (::access(dir.c_str(), W_OK) != 0)
        throw std::runtime_error(what + ": cannot write (directory " + dir.string() + ")");
}

int run_modes(const ModesArgs &a)
{
    if (a.count < 1)
        throw std::invalid_argument("--count " + std::to_string(a.count) + ": must be at least 1");
    scene::Scene sc = scene::load_scene(a.scene);
    const engine::Grid g = scene::plate_grid(sc); // refuses absurd grids, naming the keys
    if (std::size_t(a.count) >= g.node_count())
        throw std::invalid_argument("--count " + std::to_string(a.count) + ": the grid of " + std::to_string(g.nx) +
                                    " x " + std::to_string(g.ny) + " cells has only " + std::to_string(g.node_count()) +
                                    " nodes");

    // Refused before anything is built: the operator's assembly and the
    // eigensolver's factor and basis, from the node count alone.
    const model::Limits limits = model::machine_limits(a.max_memory_mb, std::nullopt);
    const double mb = 1024.0 * 1024.0;
    const double predicted_mb = model::current_rss_mb() + engine::plate_operator_bytes(g.node_count()) / mb +
                                engine::lowest_modes_bytes(g.node_count(), a.count) / mb;
    if (!(predicted_mb <= limits.memory_mb))
        throw std::runtime_error(sc.file + ": modes refused before building the operator: predicted " +
                                 io::fmt("%.0f MB", predicted_mb) + " peak memory, over this machine's " +
                                 io::fmt("%.0f MB", limits.memory_mb) + " (" + limits.memory_source + "); a grid of " +
                                 std::to_string(g.nx) + " x " + std::to_string(g.ny) + " cells of " +
                                 io::fmt("%.3g mm", g.h * 1e3) +
                                 ": lower simulation.points_per_wavelength or simulation.f_max_hz, or --count");

    // Fail before the work if the outputs cannot be written at all.
    require_writable_dir(a.output, std::filesystem::absolute(a.output).parent_path());
    if (!a.png_dir.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(a.png_dir, ec);
        if (ec)
            throw std::runtime_error(a.png_dir + ": cannot create the directory (" + ec.message() + ")");
        require_writable_dir(a.png_dir, std::filesystem::absolute(a.png_dir));
    }

    const auto t0 = std::chrono::steady_clock::now();
    const scene::PlateSetup setup = scene::build_plate(sc);
    const engine::PlateOperator &op = *setup.plate;
    if (std::size_t(a.count) >= op.unknown_count())
        throw std::invalid_argument("--count " + std::to_string(a.count) + ": the plate has only " +
                                    std::to_string(op.unknown_count()) +
                                    " nodes free to move (the others are held by its supported edges)");
    const engine::PlateModes modes = engine::lowest_modes(op, a.count);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    if (!a.png_dir.empty())
        for (int c = 0; c < a.count; ++c) {
            char name[32];
            std::snprintf(name, sizeof name, "mode-%03d.png", c + 1);
            write_mode_png((std::filesystem::path(a.png_dir) / name).string(),
                           engine::mode_field(op, modes.shapes.col(c)), g.nx + 1, g.ny + 1);
        }
    io::write_stream_atomic(a.output, [&](std::ostream &out) {
        out << "mode,frequency_hz,eigenvalue_rad2_s2,points_per_wavelength,decay_rate_1_s,t60_s,x_symmetry,"
               "y_symmetry\n";
        for (int c = 0; c < a.count; ++c) {
            const std::size_t i = std::size_t(c);
            const double f = modes.frequency_hz[i];
            // Kirchhoff A0 wavelength of the mode's frequency over the grid
            // spacing: the scheme's accuracy (docs/physics.md: ~18 points for 1 % in omega).
            const double ppw = f > 0 ? physics::kirchhoff_wavelength_m(op.kappa(), f) / g.h : 0.0;
            const double rate = modes.decay_rate_1_s[i];
            out << c + 1 << io::fmt(",%.9g", modes.frequency_hz[i]) << io::fmt(",%.9g", modes.eigenvalue_rad2_s2[i])
                << (f > 0 ? io::fmt(",%.4g", ppw) : std::string(",")) << io::fmt(",%.6g", rate)
                << (rate > 0 ? io::fmt(",%.6g", engine::t60_of_decay_rate_s(rate)) : std::string(",")) << ','
                << engine::parity_name(modes.parity_x[i]) << ',' << engine::parity_name(modes.parity_y[i]) << "\n";
        }
    });
    std::fprintf(stderr,
                 "modes: %d modes, %.4g to %.4g Hz, grid %d x %d cells of %.4g m (%zu unknowns, edges %s/%s/%s/%s), "
                 "%.3f s wall, %ld Lanczos restarts\n",
                 a.count, modes.frequency_hz.front(), modes.frequency_hz.back(), g.nx, g.ny, g.h, op.unknown_count(),
                 engine::edge_kind_name(op.params().edges.left), engine::edge_kind_name(op.params().edges.right),
                 engine::edge_kind_name(op.params().edges.bottom), engine::edge_kind_name(op.params().edges.top), wall,
                 modes.iterations);
    if (sc.effects.thick_plate || sc.effects.finger || sc.effects.exciter)
        std::fprintf(stderr, "modes: the Kirchhoff plate alone: the scene's [effects] thick_plate, finger and exciter "
                             "are not in these modes\n");
    return 0;
}

} // namespace

void register_modes(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<ModesArgs>();
    CLI::App *cmd = app.add_subcommand("modes", "The plate's lowest eigenmodes: frequencies as CSV, shapes as PNG");
    cmd->add_option("scene", a->scene, "Scene file (.toml); its [plate] and grid ([simulation])")->required();
    cmd->add_option("--count", a->count, "Number of modes, lowest first")->required();
    cmd->add_option("-o,--output", a->output,
                    "Output CSV: mode, frequency_hz, eigenvalue_rad2_s2, points_per_wavelength, decay_rate_1_s, t60_s, "
                    "x_symmetry, y_symmetry")
        ->required();
    cmd->add_option("--png", a->png_dir, "Also write one image per mode shape into this directory (mode-001.png, ...)");
    cmd->add_option("--max-memory", a->max_memory_mb,
                    "Refuse (before building anything) a job predicted to need more than this many MB (default: "
                    "physical memory)");
    cmd->callback([a, &exit_code] {
        try {
            exit_code = run_modes(*a);
        } catch (const std::exception &e) {
            std::fprintf(stderr, "calibgen modes: %s\n", e.what());
            exit_code = 1;
        }
    });
}

} // namespace calib::app
