// From a scene to what the calibration pipeline runs on: the one place that
// maps a scene's sections onto pipeline::CalibrationInput (the CLI, the
// accuracy study and the tests all go through it).
#pragma once
#include "pipeline/calibrate.h"
#include "scene/scene.h"

#include <string>
#include <string_view>

namespace calib::scene {

// `setup` is build_plate(s) (the caller may have adjusted the scene first, e.g.
// for an accuracy target); `scene_bytes` are the file's bytes, for the
// table's provenance hash. Throws SceneError naming the file when a
// calibration section is missing.
pipeline::CalibrationInput calibration_input(const Scene &s, const PlateSetup &setup, std::string_view scene_bytes);

// Parse, build the plate and collect, from scene text.
pipeline::CalibrationInput calibration_input(std::string_view toml_text, const std::string &file_name);

} // namespace calib::scene
