// calibgen: virtual calibration of time-reversal haptic plates.
#include "app/commands.h"

#include <cstdio>
#include <exception>
#include <malloc.h>

int main(int argc, char **argv)
{
    // The pipeline frees and allocates buffers of the same sizes over and
    // over (each simulation's recordings, their resampled copies); glibc
    // gives the top of its heap back to the kernel past 128 KB free, and
    // every page is then faulted in again when the next buffer takes it: on
    // a paravirtualised machine that was a quarter of a Fig. 7 calibration
    // (docs/BENCHMARKS.md, "Overlapping trapezoids"). Up to 256 MB free stay
    // in the heap; the peak is what it was.
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    CLI::App app{"calibgen " HAPTIC_VERSION ": simulate a plate and write time-reversal drive tables"};
    app.require_subcommand(1);
    int exit_code = 0;
    calib::app::register_calibrate(app, exit_code);
    calib::app::register_verify(app, exit_code);
    calib::app::register_inspect(app, exit_code);
    calib::app::register_dispersion(app, exit_code);
    calib::app::register_simulate(app, exit_code);
    calib::app::register_study(app, exit_code);
    calib::app::register_modes(app, exit_code);
    calib::app::register_measure_plan(app, exit_code);
    calib::app::register_fit(app, exit_code);
    calib::app::register_bench_record(app, exit_code);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        return app.exit(e);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "calibgen: %s\n", e.what());
        return 1;
    }
    return exit_code;
}
