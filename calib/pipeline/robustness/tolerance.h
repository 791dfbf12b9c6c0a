// Perturbed plates and what a table keeps on them (docs/robustness.md).
//
// A perturbed plate is the nominal one with E, rho, the thickness and the
// loss scaled, on the nominal grid (so a tolerance is not confused with a
// change of discretisation), its exciters optionally moved. The loss keeps
// its law: a panel with the same loss factor eta(omega) but another kappa has
// the same sigma(omega) = sigma0 + sigma1 omega / kappa, so sigma1 follows
// kappa; a loss perturbation then scales sigma0 and sigma1 together. The time
// step stays the nominal one while it is stable on the perturbed plate (the
// same scheme, only the plate changed), else the perturbed plate's own
// Courant step. A table is verified on it from the transfer matrix of that
// plate (one simulation per exciter), exactly as calibrate verifies the
// nominal one.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/data/verdict.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace calib::pipeline {

// Loss factor of the plate at f: eta = 2 sigma(omega) / omega (0 without loss).
double loss_factor(const engine::PlateOperator &plate, double f_hz);

// The box with the material's defaults filled in (loss range, dE/dT).
struct ResolvedTolerance {
    ToleranceSpec spec;
    double nominal_loss = 0; // eta at the pulse centre
    double youngs_per_kelvin = 0;
    bool loss_range = false; // spec.loss_min/max hold a range
};
ResolvedTolerance resolve_tolerance(const CalibrationInput &in, const ToleranceSpec &t);

// Refuses a box that makes a plate impossible, before any simulation
// (std::invalid_argument, one line naming the key): a loss the scene's forced
// time step cannot take, a loss range on a plate without loss, a scene whose
// plate is not time-invariant ([effects.finger]).
void check_tolerance(const CalibrationInput &in, const ToleranceSpec &t);

// Each tolerance at both ends of its range, one at a time (exciters: every
// one moved by the full distance in a seeded direction, then in the opposite
// one).
std::vector<Perturbation> one_at_a_time(const CalibrationInput &in, const ToleranceSpec &t);
// `n` plates with every tolerance drawn uniformly in its range (seeded).
std::vector<Perturbation> random_combinations(const CalibrationInput &in, const ToleranceSpec &t, unsigned n,
                                              uint64_t seed);
// Loss factor eta at the pulse centre, as a perturbation of the nominal plate.
Perturbation loss_case(const CalibrationInput &in, double eta, const std::string &factor);

// The scene's input on the perturbed plate. Throws std::invalid_argument for
// an impossible plate or a forced time step it cannot take.
CalibrationInput perturbed_input(const CalibrationInput &in, const Perturbation &p);
std::vector<Point> moved_exciters(const CalibrationInput &in, const std::vector<Point> &exciters,
                                  const Perturbation &p);

// H of the perturbed plate for these exciters: the nominal observation
// lattice (when `lattice`) and the foci.
TransferMatrix perturbed_transfer(const CalibrationInput &nominal, const CalibrationInput &perturbed,
                                  const std::vector<Point> &exciters, bool lattice, const ProgressFn &progress = {});

// H of a plate that differs from the nominal one only in kappa (by a factor
// alpha) and in the mass per area m = rho d (E, rho, d; the loss law kept),
// without a new simulation: with the step k / alpha the scheme's update is the
// nominal one step for step (mu = kappa k / h^2, sigma1 k and the sigma0 k of
// a loss law with sigma0 = 0 are unchanged) and the force term
// k^2 F / (m h^2) of the same index-domain force is (m_0 / m) / alpha times
// the nominal, so H' = H (m_0 / m) / alpha at the rate alpha / (M k): exact
// for the scheme (to float round-off; the force's band edges move by alpha
// with the rate). Only the last (1 - 1/alpha) of the verification tail lies
// beyond the stored samples for alpha > 1 (the field there is taken as zero).
// Empty when it does not apply (moved exciters, another loss, sigma0 != 0
// with alpha != 1, the thick plate).
std::optional<TransferMatrix> rescaled_transfer(const CalibrationInput &nominal, const CalibrationInput &perturbed,
                                                const TransferMatrix &H, const Perturbation &p);

// `signals` (interleaved frames of `channels`) as the device plays them on a
// panel `speed_ratio` times as fast as the nominal plate (common/haptic_stretch.h).
// Throws std::invalid_argument for a ratio a device does not stretch by.
std::vector<std::vector<int16_t>> stretched(const std::vector<std::vector<int16_t>> &signals, std::size_t channels,
                                            double speed_ratio);

// The figures of one verification of `signals` (for the drive energy).
CaseFigures figures_of(const Verification &v, const std::vector<std::vector<int16_t>> &signals,
                       double force_full_scale_n, double rate_hz);
// Worst of every figure (least contrast, least peak, most offset, most fails...).
CaseFigures worst_of(const std::vector<CaseFigures> &all);

// A table as stored: quantized signals per focus at a rate.
struct StoredTable {
    std::vector<std::vector<int16_t>> signals;
    double rate_hz = 0;
};

// Verifies `table` (and `plain`, when given) on every perturbed plate; the
// transfer matrix of each plate is simulated once and serves both. With the
// nominal H (`nominal_H`, lattice and foci), the plates it gives exactly
// (rescaled_transfer) are not simulated again.
std::vector<ToleranceCase> evaluate_cases(const CalibrationInput &in, const std::vector<Point> &exciters,
                                          const std::vector<Perturbation> &cases, const StoredTable &table,
                                          const StoredTable *plain, const ProgressFn &progress = {},
                                          const TransferMatrix *nominal_H = nullptr);

} // namespace calib::pipeline
