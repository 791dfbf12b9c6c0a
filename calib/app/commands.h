// Subcommands of calibgen. Each lives in its own cmd_*.cpp and registers
// itself on the CLI11 app; main() only lists them.
#pragma once
#include <CLI/CLI.hpp>

namespace calib::app {

// Every register_* adds one subcommand whose callback sets `exit_code`.
void register_inspect(CLI::App &app, int &exit_code);
void register_calibrate(CLI::App &app, int &exit_code);
void register_verify(CLI::App &app, int &exit_code);
void register_dispersion(CLI::App &app, int &exit_code);
void register_simulate(CLI::App &app, int &exit_code);
void register_study(CLI::App &app, int &exit_code);
void register_modes(CLI::App &app, int &exit_code);
void register_fit(CLI::App &app, int &exit_code);
void register_bench_record(CLI::App &app, int &exit_code);
void register_measure_plan(CLI::App &app, int &exit_code);

} // namespace calib::app
