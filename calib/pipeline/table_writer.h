// The drive table of a calibration, written with common/ (the one definition
// of the format, docs/table-format.md).
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"

#include <string>

namespace calib::pipeline {

// Writes the table atomically with common/ (scale_m from the verification).
void write_table(const std::string &path, const CalibrationInput &in, const CalibrationResult &result);

} // namespace calib::pipeline
