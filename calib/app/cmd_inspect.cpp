// `calibgen inspect FILE`: validate a table and print its summary.
#include "app/commands.h"

#include <haptic_table.h>

#include <cstdio>
#include <memory>
#include <string>

namespace calib::app {

void register_inspect(CLI::App &app, int &exit_code)
{
    auto path = std::make_shared<std::string>();
    CLI::App *cmd = app.add_subcommand("inspect", "Validate a calibration table and print a summary");
    cmd->add_option("table", *path, "Table file (.htab)")->required();
    cmd->callback([path, &exit_code] {
        haptic_table table{};
        haptic_table_error err{};
        if (haptic_table_open(path->c_str(), &table, &err) != 0) {
            std::fprintf(stderr, "calibgen: %s: %s\n", path->c_str(), err.message);
            exit_code = 1;
            return;
        }
        haptic_table_print_summary(&table, path->c_str(), stdout);
        haptic_table_close(&table);
        exit_code = 0;
    });
}

} // namespace calib::app
