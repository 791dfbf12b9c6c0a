// A bench recording simulated on a plate the fit did not make (docs/bench.md,
// the worked example; the tests): the measurement plan played through a
// scene's exciters (fixed positions, their force gains), recorded at the
// sensors in their quantity and units, with white noise. The "real" plate is
// a scene of its own (a finer grid, another modulus and loss, moved
// exciters), so the fitted model meets the discretisation it would meet on
// a real panel.
#pragma once
#include "pipeline/bench/bench_model.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace calib::pipeline {

struct SyntheticRecording {
    std::vector<std::vector<double>> channels; // [sensor][frame], recorded units (full scale 1)
    std::vector<double> units_per_count;       // what each sensor's unit is worth (SI per recorded unit)
    std::vector<double> noise_rms;             // per sensor, recorded units
};

// `plan[c]`: exciter c's drive (full scale 1) at rate_hz. The plate's
// responses are simulated for `response_s` (the plan's silence between
// exciters) and cover the band up to f_max_hz. A sensor without
// units_per_count gets one that puts its peak at half of full scale.
// noise_db: the noise's RMS relative to the RMS of the sensor's signal while
// an exciter sweeps (-30: 30 dB below). Throws std::invalid_argument for a
// scene without fixed exciters.
SyntheticRecording synthesize_recording(const CalibrationInput &truth, const std::vector<BenchSensor> &sensors,
                                        const std::vector<std::optional<double>> &units_per_count,
                                        const std::vector<std::vector<double>> &plan, double rate_hz, double response_s,
                                        double f_max_hz, double noise_db, uint64_t seed,
                                        const ProgressFn &progress = {});

} // namespace calib::pipeline
