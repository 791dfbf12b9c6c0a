// The inverse filter: drives designed from the transfer matrix H for what the
// whole active area should do, not only the focus (Woo, JSV 2015; Pantera &
// Hudin, IEEE ToH 2020). Time domain, regularised least squares:
//
//   minimise  W_f sum_n (w_f[n] - d[n])^2 + sum_{q in Q} sum_n w_q[n]^2
//             + beta sum_c s_c^T (I + rho P_out) s_c
//
// over causal drives s_c[j], j < J (J: the lead time at H's rate, so the
// drive is no longer than the lead time; plus the scene's active_damping_s,
// a drive that goes on after the focal instant and, held to the same
// objective, takes the reverberation out of the plate), where w_p = (1/R) sum_c h_cp * s_c
// is the playback (transfer/playback.h), d the pulse centred at the focus instant, Q
// the control points (the observation lattice in the active area and the
// other foci, farther than lambda/2 from the focus), and n runs over the
// whole support of the playback (J + S - 1 samples): zero at all times, as
// the whole-area verification measures it.
//
// Why the time domain: "causal and at most the lead time long" is a support
// constraint, exact here; a per-frequency solve gives a non-causal, circular
// drive that must be windowed afterwards, which undoes part of what it solved.
// Over the whole support the normal matrix is block Toeplitz,
//   G[(c,j),(c',j')] = sum_p w_p sum_m h_cp[m] h_c'p[m + j - j'],
// so it is formed from cross-spectra accumulated point by point (FFT), and the
// system is C J unknowns however many control points there are: every lattice
// point of the active area serves, none is subsampled away. A scene's foci
// share the per-point correlations (inverse_filter_designs), and the block
// Toeplitz system is solved by block Levinson in O(C^3 J^2), checked by its
// residual against what a Cholesky solve leaves (Cholesky where it falls short).
//
// Regularisation rule: beta = epsilon * lambda_max(G), epsilon the scene's
// `regularization` (default 1e-4: on Fig. 7 with the minimax refinement below,
// 8.3 dB worst whole-area contrast against 8.1 dB at 1e-3 and 6.6 dB at 1e-2;
// docs/REPRODUCTION.md). Relative to the largest eigenvalue, the
// rule is independent of units, plate and exciter count, and it bounds the
// condition number of the regularised system by about 1 / epsilon (plus the
// out-of-band weight below): with the default, directions the plate
// transmits more than 40 dB (in power) below its best are not inverted. epsilon -> 0 is the least-squares inverse (exact where the
// system is solvable, Miyoshi & Kaneda's MINT: fewer points than exciters and
// J >= Q (S - 1) / (C - Q)); epsilon -> infinity is s -> W_f A_f^T d / beta,
// the matched filter, i.e. time reversal up to scale.
//
// Audible energy: the target is band-limited to the pulse; above the pulse's
// band (its -40 dB edge) the drive's energy costs rho = 100 times more in the
// penalty (P_out is the exact quadratic form of the drive's energy above the
// edge, a Toeplitz matrix of the ideal high-pass). The penalty scales with
// beta, so both limits above hold unchanged.
//
// Least squares weighs every control point and instant alike; the verdict is
// the worst point (a sidelobe ring just beyond lambda/2 at the focal instant,
// on Fig. 7). Lawson's iteratively reweighted least squares moves the design
// towards the minimax one: each control point's weight grows with its largest
// |w| relative to the worst (InverseFilterOptions::minimax_iterations). The device signal is the drive
// resampled to the output rate (no content above H's Nyquist rate) with the
// same raised-cosine fades as time reversal (finishing.h).
//
// Stacked over plates (the robust design, robustness/robust_design.h): one drive for several
// transfer matrices H_m of the same exciters and points (the nominal plate
// and perturbed ones), minimising the sum over m of the objective above on
// H_m. Its normal equations are the sums of the plates': G = sum_m G_m,
// b = sum_m b_m (the penalty once), and the regularisation stays relative:
// beta = epsilon lambda_max(sum_m G_m). So M identical plates give the plain
// design (G, b and beta all scale by M), and the rule keeps its meaning
// however many plates are stacked. The minimax refinement weighs a control
// point by its largest |w| over time and over all plates, and keeps the
// design with the best ratio of the weakest plate's focal peak to the worst
// control point over the plates.
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"
#include "pipeline/data/transfer_matrix.h"

#include <cstddef>
#include <vector>

namespace calib::pipeline {

struct InverseFilterOptions {
    double regularization = 1e-4;    // epsilon: beta = epsilon lambda_max(G); 0 = unregularised
    double focus_weight = 1.0;       // W_f: the focus's rows against one control point's
    double band_edge_hz = 0;         // out-of-band penalty above this; <= 0: none
    double out_of_band_weight = 100; // rho
    // Minimax refinement (Lawson's iteratively reweighted least squares): after
    // each design, every control point's weight is multiplied by its largest
    // |w| over time relative to the worst point's, and the design repeated;
    // the design with the best focal peak over the worst control point wins.
    // 0: plain least squares.
    int minimax_iterations = 8;
};

struct InverseFilterProblem {
    // Indices into H.points, each with the target d. One focus is the table's
    // design; several are the joint design of a set (several fingers at
    // once): minimise W_f sum_{f in F} sum_n (w_f[n] - d[n])^2 + the rest.
    std::vector<std::size_t> foci;
    std::vector<std::size_t> control;    // indices into H.points, target zero
    std::vector<double> control_weights; // per control point (empty: 1 each)
    std::vector<double> target;          // d[n] at the focus from playback start, H's rate (zero after)
    std::size_t drive_samples = 0;       // J
};

struct InverseFilterDesign {
    std::vector<std::vector<double>> drive; // [c][j], force (N) at H's rate, j < J
    double lambda_max = 0;                  // of the data part of G (summed over the plates)
    double beta = 0;
};

// The plates of a stacked design: the nominal H first, then the others, all
// with the same channels, samples, rate and points (resample a plate's H
// first if its rate differs).
using Plates = std::vector<const TransferMatrix *>;

// Throws std::invalid_argument for an empty problem, std::runtime_error when
// the solve fails.
InverseFilterDesign design_inverse_filter(const TransferMatrix &H, const InverseFilterProblem &problem,
                                          const InverseFilterOptions &options);
// Stacked over plates (above); also throws std::invalid_argument when the
// plates do not match.
InverseFilterDesign design_inverse_filter(const Plates &plates, const InverseFilterProblem &problem,
                                          const InverseFilterOptions &options);

// design_inverse_filter with the options' minimax refinement (the problem's
// control weights are where it starts from: ignored, all 1). With several
// foci the design kept is the one with the best weakest focal peak over the
// worst control point.
InverseFilterDesign minimax_design(const TransferMatrix &H, InverseFilterProblem problem,
                                   const InverseFilterOptions &options);
InverseFilterDesign minimax_design(const Plates &plates, InverseFilterProblem problem,
                                   const InverseFilterOptions &options);

// The control points of focus f (index into the scene's foci): lattice points
// in the active area and the other foci, farther than lambda/2 at the pulse
// centre from it.
std::vector<std::size_t> control_points(const CalibrationInput &in, const TransferMatrix &H, std::size_t f);
// ... of a set of foci: farther than lambda/2 from every one of them.
std::vector<std::size_t> control_points(const CalibrationInput &in, const TransferMatrix &H,
                                        const std::vector<std::size_t> &set);

// The pulse centred at `centre_s` from playback start, at H's rate.
std::vector<double> focus_target(const CalibrationInput &in, double rate_hz, double centre_s);

// Per focus, the inverse-filter drives at full scale for the scene's lead
// time (data/lead_time.h) and regularization; progress("signals", done, foci).
std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                                 const ProgressFn &progress = {});
// Stacked over plates (the nominal H first; the foci and the control points
// are its).
std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const Plates &plates,
                                                 const ProgressFn &progress = {});

// The designs behind inverse_filter_signals (minimax_design of each focus's
// problem), at H's rate before the fades and the resampling. The foci share
// what does not depend on the focus: the normal matrix of focus f is
// sum_{p in Q_f} w_p G_p + W_f G_f, G_p the block Toeplitz matrix of point
// p's cross-correlations, so each point's are computed once for every focus
// and minimax pass, and a design weighs them (zero at the points it does not
// control); one playback serves every focus's refinement; the foci are
// designed in parallel. `shared` false designs each focus from scratch (the
// reference: the same drives to round-off, test_inverse_filter_shared).
std::vector<InverseFilterDesign> inverse_filter_designs(const CalibrationInput &in, const Plates &plates,
                                                        const ProgressFn &progress = {}, bool shared = true);

// The scene's drive length J at `rate_hz` (H's): its lead time, and its
// active damping after the focal instant.
std::size_t scene_drive_samples(const CalibrationInput &in, double rate_hz);
// The lattice points in the active area (indices into `lattice`): with the
// foci, the points a scene's designs weigh (control_points draws from them).
std::vector<std::size_t> lattice_in_area(const CalibrationInput &in, const ObservationLattice &lattice);

// The scene's options (regularization, band edge, minimax passes).
InverseFilterOptions scene_inverse_filter_options(const CalibrationInput &in);

// The joint design of a set of foci (indices into the scene's foci; several
// fingers at once): one drive with every foci row of the set targeting the
// pulse at the scene's focus instant, the control points farther than
// lambda/2 from all of them, the scene's lead time and regularization, at
// full scale, pre-compensated for the exciter when the scene's tables are. A
// set of one is that focus's plain table design (but for the dither seed).
DriveSignals joint_inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                          const std::vector<std::size_t> &set);

} // namespace calib::pipeline
