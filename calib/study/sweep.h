// A design sweep (`calibgen study design SWEEP.toml`): a base scene and the
// axes to vary. Each case is the base scene with the swept keys overridden;
// the cases are the cartesian product of the axes, enumerated in a fixed
// order (first axis of the file outermost), each with an id hashed from its
// scene text, so a case keeps its id and its result file across reruns,
// sweeps, machines and rank counts. docs/design-studies.md documents the file.
#pragma once

#include <toml++/toml.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace calib::study {

// One line: "<file>: <key>: <what is wrong>".
class SweepError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// What an axis varies. Each maps onto one scene key.
enum class AxisKind {
    exciter_count,       // exciters.count (integer)
    material,            // plate.material (a built-in name)
    thickness_m,         // plate.thickness_m
    pulse_centre_hz,     // pulse.centre_hz
    pulse_cycles,        // pulse.cycles
    edges,               // plate.edges ("clamped", ... or {left, right, bottom, top})
    placement_criterion, // exciters.criterion
    seed,                // exciters.seed (integer)
};

struct Axis {
    AxisKind kind;
    std::string name;   // the key in [axes]
    toml::array values; // each value as the case scene gets it
};

// Limits the summary applies when it names the best case (all optional).
struct Constraints {
    std::optional<double> min_contrast_db;
    std::optional<double> max_spot_m;
    std::optional<double> max_lead_time_s;
    std::optional<unsigned> max_exciters;
};

struct Case {
    std::size_t index = 0;
    std::string id;                  // 16 hex digits: FNV-1a 64 of scene_text
    std::string scene_text;          // the base scene with this case's keys set (TOML)
    std::vector<std::string> values; // per axis, as written in the sweep (for progress lines)
};

struct Sweep {
    std::string file;      // as given, for messages
    std::string base_path; // resolved against the sweep file's folder
    std::string base_text;
    std::string name; // [study] name, default: the sweep file's stem
    toml::table set;  // [set]: scene keys every case gets (axes override them)
    std::vector<Axis> axes;
    Constraints constraints;
    std::size_t case_count() const;
};

// Throws SweepError (one line naming the file and the key) for an unknown
// axis or key, an empty list or range, a value of the wrong type, a base
// scene that cannot be read, or more than `max_cases` cases.
Sweep parse_sweep(std::string_view toml_text, const std::string &file_name, std::size_t max_cases = 100000);
Sweep load_sweep(const std::string &path);

// The cases in order: the cartesian product, the last axis varying fastest.
std::vector<Case> enumerate_cases(const Sweep &sweep);

// The known axis names, comma separated (for messages and docs).
std::string known_axis_names();

// FNV-1a 64 of the bytes, as 16 lower-case hex digits.
std::string fnv1a_hex(std::string_view bytes);

} // namespace calib::study
