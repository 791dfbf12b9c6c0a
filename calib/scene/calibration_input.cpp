#include "scene/calibration_input.h"

#include "scene/toml_fields.h"

namespace calib::scene {

pipeline::CalibrationInput calibration_input(const Scene &s, const PlateSetup &setup, std::string_view scene_bytes)
{
    if (!s.calibration_sections())
        throw SceneError(s.file + ": not a calibration scene: it needs [active_area], [exciters], [foci], [pulse] "
                                  "and [calibration] sections");
    pipeline::CalibrationInput in;
    in.scene_name = s.name;
    in.scene_hash = pipeline::scene_hash(std::string(scene_bytes));
    in.plate = setup.plate;
    in.simulation = setup.options;
    in.active = *s.active_area;
    in.exciters = *s.exciters;
    in.foci = *s.foci;
    in.pulse = *s.pulse;
    in.calibration = *s.calibration;
    in.effects = s.effects;
    in.tolerance = s.tolerance;
    in.robust = s.robust;
    in.plate_temperature_c = s.plate.temperature_c;
    return in;
}

pipeline::CalibrationInput calibration_input(std::string_view toml_text, const std::string &file_name)
{
    const Scene s = parse_scene(toml_text, file_name);
    return calibration_input(s, build_plate(s), toml_text);
}

} // namespace calib::scene
