// calibgen: virtual calibration of time-reversal haptic plates.
#include "app/commands.h"
#include "io/heap.h"

#include <cstdio>
#include <exception>

int main(int argc, char **argv)
{
    calib::io::keep_freed_heap();
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
