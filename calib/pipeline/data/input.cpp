#include "pipeline/data/input.h"

#include "io/format.h"
#include "physics/dispersion.h"

#include <zlib.h>

namespace calib::pipeline {

double judged_lambda_half_m(const CalibrationInput &in)
{
    return in.lambda_half_m > 0 ? in.lambda_half_m
                                : physics::kirchhoff_wavelength_m(in.plate->kappa(), in.pulse.centre_hz) / 2;
}

bool transfer_holds(const CalibrationInput &in) { return !in.effects.finger; }

engine::SimulationOptions single_core_options(const CalibrationInput &in)
{
    engine::SimulationOptions o = in.simulation;
    o.engine.threads = 1; // the simulations run in parallel; each keeps to one core
    o.thick_plate = in.effects.thick_plate;
    return o;
}

Band band_of(const CalibrationInput &in)
{
    Band b;
    b.plate_x_m = in.plate->params().size_x_m;
    b.plate_y_m = in.plate->params().size_y_m;
    b.frame_margin_m = in.active.frame_margin_m;
    b.active_area = in.active.area;
    b.clearance_m = in.active.clearance_m;
    return b;
}

std::string scene_hash(const std::string &bytes)
{
    const uLong c =
        crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef *>(bytes.data()), static_cast<uInt>(bytes.size()));
    return io::fmt("crc32:%08lx", static_cast<unsigned long>(c));
}

} // namespace calib::pipeline
