#include "engine/effects/exciter.h"

#include <unsupported/Eigen/FFT>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace calib::engine::effects {

void check_exciter(const ExciterSpec &e)
{
    if (!(e.moving_mass_kg > 0) || !std::isfinite(e.moving_mass_kg))
        throw std::invalid_argument("moving_mass_kg: must be > 0");
    if (!(e.stiffness_n_m >= 0) || !std::isfinite(e.stiffness_n_m))
        throw std::invalid_argument("stiffness_n_m: must be >= 0");
    if (!(e.damping_n_s_m >= 0) || !std::isfinite(e.damping_n_s_m))
        throw std::invalid_argument("damping_n_s_m: must be >= 0");
    if (!(e.force_factor_n_a > 0) || !std::isfinite(e.force_factor_n_a))
        throw std::invalid_argument("force_factor_n_a: must be > 0");
    if (!(e.max_boost_db >= 0) || !(e.max_boost_db <= 60))
        throw std::invalid_argument("max_boost_db: must lie in [0, 60]");
}

std::complex<double> exciter_transfer(const ExciterSpec &e, double f_hz)
{
    const std::complex<double> s(0.0, 2 * std::numbers::pi * f_hz);
    const std::complex<double> ms2 = e.moving_mass_kg * s * s;
    return ms2 / (ms2 + e.damping_n_s_m * s + e.stiffness_n_m);
}

double exciter_resonance_hz(const ExciterSpec &e)
{
    return std::sqrt(e.stiffness_n_m / e.moving_mass_kg) / (2 * std::numbers::pi);
}

double exciter_q(const ExciterSpec &e)
{
    if (e.damping_n_s_m == 0)
        return std::numeric_limits<double>::infinity();
    return std::sqrt(e.stiffness_n_m * e.moving_mass_kg) / e.damping_n_s_m;
}

ExciterExtension::ExciterExtension(const PointField &engine, double x_m, double y_m, const ExciterSpec &spec)
    : spec_(spec), k_(engine.time_step()), point_(engine.couple(x_m, y_m, "exciter"))
{
    check_exciter(spec);
    // The suspension is explicit at the magnet: leapfrog needs (omega0 k)^2 =
    // s k^2 / M < 4; keep a factor 2 of margin (omega0 k < 1.4: far beyond any
    // real exciter's resonance at the plate's time step).
    if (spec.stiffness_n_m * k_ * k_ / spec.moving_mass_kg >= 2.0)
        throw std::invalid_argument("exciter: resonance too high for the time step");
}

void ExciterExtension::set_drive(std::vector<double> current_a)
{
    drive_ = std::move(current_a);
    n_ = 0;
    forces_.clear();
    forces_.reserve(drive_.size());
}

void ExciterExtension::after_update(PointField &engine)
{
    const auto [wp, w, wm] = engine.read(point_);
    const double i = n_ < drive_.size() ? drive_[n_] : 0.0;
    ++n_;
    const double M = spec_.moving_mass_kg, c = spec_.damping_n_s_m, s = spec_.stiffness_n_m, k = k_;
    // M a = -s (z - W) - c/(2k) (k^2 a + 2 (z - z-) - W+ + W-) - Bl i, W+ = W+free - g M a.
    const double rhs = -s * (z_ - w) - c / (2 * k) * (2 * (z_ - z_prev_) - wp + wm) - spec_.force_factor_n_a * i;
    const double a = rhs / (M + c * k / 2 + c * point_.g * M / (2 * k));
    const double force = -M * a;
    const double z_next = k * k * a + 2 * z_ - z_prev_;
    z_prev_ = z_;
    z_ = z_next;
    engine.apply(point_, force);
    forces_.push_back(force);
}

namespace {

// Multiplies the spectrum of `signal` (zero-padded to >= 2x) by gain(T(f)).
template <typename Gain>
std::vector<double> filter_by_transfer(const std::vector<double> &signal, double rate_hz, const ExciterSpec &e,
                                       Gain gain)
{
    if (signal.empty())
        return {};
    std::size_t nfft = 1;
    while (nfft < 2 * signal.size())
        nfft *= 2;
    std::vector<double> buf(nfft, 0.0);
    std::copy(signal.begin(), signal.end(), buf.begin());
    Eigen::FFT<double> fft;
    std::vector<std::complex<double>> spec;
    fft.fwd(spec, buf);
    for (std::size_t b = 0; b < spec.size(); ++b) {
        const std::size_t bin = b <= nfft / 2 ? b : nfft - b;
        std::complex<double> t = exciter_transfer(e, double(bin) * rate_hz / double(nfft));
        if (b > nfft / 2)
            t = std::conj(t); // real signal: T(-f) = conj T(f)
        spec[b] *= gain(t);
    }
    fft.inv(buf, spec);
    buf.resize(signal.size());
    return buf;
}

} // namespace

std::vector<double> blocked_force(const std::vector<double> &bl_i, double rate_hz, const ExciterSpec &e)
{
    check_exciter(e);
    return filter_by_transfer(bl_i, rate_hz, e, [](std::complex<double> t) { return t; });
}

double exciter_plate_loading(const ExciterSpec &e, double bending_stiffness, double mass_per_area, double f_hz)
{
    const std::complex<double> s(0.0, 2 * std::numbers::pi * f_hz);
    const double M = e.moving_mass_kg, c = e.damping_n_s_m, k = e.stiffness_n_m;
    const std::complex<double> zm = M * s * s * (c * s + k) / (M * s * s + c * s + k);
    const double mobility = 1.0 / (8.0 * std::sqrt(bending_stiffness * mass_per_area));
    return std::abs(zm / s) * mobility;
}

std::vector<double> precompensate(const std::vector<double> &signal, double rate_hz, const ExciterSpec &e)
{
    check_exciter(e);
    // |C| = |T| / (|T|^2 + eps^2) peaks at 1 / (2 eps).
    const double max_boost = std::pow(10.0, e.max_boost_db / 20.0);
    const double eps = 1.0 / (2.0 * max_boost);
    return filter_by_transfer(signal, rate_hz, e,
                              [eps](std::complex<double> t) { return std::conj(t) / (std::norm(t) + eps * eps); });
}

} // namespace calib::engine::effects
