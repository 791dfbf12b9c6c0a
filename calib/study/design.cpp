#include "study/design.h"

#include "io/atomic_file.h"
#include "io/format.h"
#include "io/read_file.h"
#include "scene/scene.h"
#include "scene/toml_fields.h"
#include "study/design_case.h"
#include "study/design_report.h"
#include "study/sweep.h"
#include "study/workers.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>

namespace calib::study {

namespace {

namespace fs = std::filesystem;

// A finished case's result, if its file is whole and is this case's.
std::optional<CaseResult> stored_result(const fs::path &dir, const Case &c)
{
    const fs::path p = dir / case_file_name(c);
    const auto text = io::read_file(p.string());
    if (!text)
        return std::nullopt;
    try {
        CaseResult r = decode_case(*text, p.string());
        if (r.id != c.id)
            return std::nullopt;
        r.index = c.index; // the same case may sit elsewhere in a reordered sweep
        return r;
    } catch (const std::exception &) {
        return std::nullopt; // not ours or damaged: run the case again
    }
}

std::string case_label(const Sweep &s, const Case &c)
{
    std::string l;
    for (size_t a = 0; a < s.axes.size(); a++)
        l += (l.empty() ? "" : " ") + s.axes[a].name + "=" + c.values[a];
    return l.empty() ? "base scene" : l;
}

} // namespace

int run_design_study(const DesignOptions &o)
{
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    // Every rank reads the sweep and enumerates the same cases (deterministic);
    // a sweep that is refused is refused on every rank, before MPI starts.
    const Sweep sweep = load_sweep(o.sweep_path);
    const std::vector<Case> cases = enumerate_cases(sweep);
    // A value the scene refuses (an unknown material, a negative thickness)
    // stops the sweep before anything runs, naming the sweep and the case.
    for (const Case &c : cases) {
        try {
            (void)scene::parse_scene(c.scene_text, sweep.base_path);
        } catch (const scene::SceneError &e) {
            throw SweepError(sweep.file + ": case " + std::to_string(c.index) + " (" + case_label(sweep, c) +
                             "): " + e.what());
        }
    }
    const fs::path dir = o.report_dir, case_dir = dir / "cases";

    std::unique_ptr<Workers> workers = start_workers();
    const int rank = workers->rank();
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    const int threads = o.threads > 0 ? o.threads : std::max(1, int(cores) / std::max(1, workers->local_size()));

    std::vector<size_t> todo;
    if (rank == 0) {
        std::error_code ec;
        fs::create_directories(case_dir, ec);
        if (ec)
            throw std::runtime_error(case_dir.string() + ": cannot create: " + ec.message());
        // Temporary files of a killed run are never results: clear them.
        for (const auto &e : fs::directory_iterator(case_dir))
            if (e.path().filename().string().find(".case.tmp.") != std::string::npos)
                fs::remove(e.path(), ec);
        for (const Case &c : cases)
            if (!stored_result(case_dir, c))
                todo.push_back(c.index);
        if (!o.quiet)
            std::fprintf(stderr, "design: %zu cases, %zu already done, %zu to run (%s, %d rank%s x %d thread%s)\n",
                         cases.size(), cases.size() - todo.size(), todo.size(), workers->kind(), workers->size(),
                         workers->size() == 1 ? "" : "s", threads, threads == 1 ? "" : "s");
    }
    size_t finished = 0;
    const size_t to_run = todo.size();
    workers->run(
        todo,
        [&](size_t i) {
            omp_set_num_threads(threads); // per calling thread: the case's OpenMP regions
            return encode_case(run_case(sweep, cases[i], rank));
        },
        [&](size_t i, const std::string &record) {
            io::write_file_atomic((case_dir / case_file_name(cases[i])).string(), record);
            finished++;
            if (!o.quiet) {
                const CaseResult r = decode_case(record, case_file_name(cases[i]));
                std::fprintf(stderr, "[%zu/%zu] case %zu (%s) rank %d: %s, %.1f s\n", finished, to_run, i,
                             case_label(sweep, cases[i]).c_str(), r.rank,
                             r.ran ? io::fmt("contrast %.1f dB", r.worst_contrast_db).c_str()
                                   : ("refused: " + r.note).c_str(),
                             r.wall_s);
            }
        });
    if (rank != 0)
        return 0;
    std::vector<CaseResult> results;
    for (const Case &c : cases) {
        auto r = stored_result(case_dir, c);
        if (!r)
            throw std::runtime_error((case_dir / case_file_name(c)).string() + ": case " + std::to_string(c.index) +
                                     " has no result after the run");
        results.push_back(*r);
    }
    const std::string md = write_design_report(sweep, results, dir.string());
    if (!o.quiet)
        std::printf("%s", md.c_str());
    if (!o.quiet)
        std::fprintf(stderr, "design: wrote %s/{design.csv,timing.csv,summary.md,*.svg,*.png} in %.1f s\n",
                     dir.string().c_str(), std::chrono::duration<double>(Clock::now() - t0).count());
    return 0;
}

} // namespace calib::study
