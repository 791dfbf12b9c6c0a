// Several fingers at once, verified from H: the device superposes the stored
// single-focus signals of the touched foci with the firmware's energy
// normalisation (firmware/src/mixer.h): y = g sum_{f in S} s_f with
//   g = min(sqrt(E_ref / E_sum), 32767 / P(S), 1),
// E_ref the mean energy of the selected foci alone, E_sum the energy of the
// unscaled sum (from the Gram matrix of the stored counts), P(S) the
// firmware's block bound of the sum's peak (64-frame blocks) and 1 the
// default gain limit. The mix is played through H (transfer/playback.h) and read at
// every time: each touched focus must reach the threshold, and nothing in
// the active area farther than lambda/2 from every touched focus may.
//
// Against it, with the inverse filter, the joint design of the set
// (design/inverse_filter.h: one drive, every touched focus a target row, the control
// points beyond lambda/2 of all of them) under the same budget: the energy
// the mix plays (E_mix = g^2 E_sum), full scale, and no touched focus louder
// than the scene's amplitude (the scene asks for no more at a focus):
//   g_joint = min(sqrt(E_mix / E_joint), 1, amplitude / max_f peak_f),
// the joint drive stored at full scale (E_joint its energy, peak_f its focal
// peaks there). What a table of single foci loses against a drive made for
// the set, per pair and triple. A robust table (calibration.robust) has no
// joint counterpart here (the joint design is of the nominal plate): refused.
#pragma once
#include "pipeline/data/geometry.h"
#include "pipeline/data/transfer_matrix.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct CalibrationInput;

// One drive of a set played through H.
struct SetVerdict {
    double gain = 0;             // the firmware's g (superposition) or g_joint
    double energy = 0;           // of the drive played, counts^2 (full scale 32767)
    double min_focus_peak_m = 0; // the weakest touched focus
    double max_focus_peak_m = 0; // the loudest touched focus
    double max_elsewhere_m = 0;  // largest |w| beyond lambda/2 of every touched focus, all times
    Point elsewhere_at;
    // min(weakest focus - threshold, threshold - max elsewhere): > 0 when ok.
    double margin_m = 0;
    bool ok = false; // every touched focus crosses, nothing else does
    // Weakest focus over max elsewhere (dB): the set's contrast.
    double contrast_db() const;
};

struct MultiTouchCase {
    std::vector<std::size_t> foci; // indices into the scene's foci
    SetVerdict superposed;         // the firmware's mix of the stored foci
    bool has_joint = false;
    SetVerdict joint; // the set's joint inverse filter (MultiTouchOptions::joint)
};

struct MultiTouchReport {
    std::vector<MultiTouchCase> cases;
    std::size_t worst = 0;   // least superposed margin_m
    std::size_t failing = 0; // superposed
};

struct MultiTouchOptions {
    bool triples = false; // every triple of foci >= lambda/2 apart too
    bool joint = false;   // design each set jointly too (the inverse filter)
};

// What the device plays for a set of stored foci ([n][c] int16 counts; a
// shorter signal ends in silence) played together: the mixing law of
// common/haptic_mix.h (the one hapticd calls) at the user's level and the
// board's gain limit, applied in Q30 and rounded to S16 as the device does,
// so calibgen judges the device's samples, not a model of them.
struct DeviceMix {
    double gain = 0;              // the law's g
    std::vector<int16_t> samples; // [n][c], the longest signal's length
};
DeviceMix device_mix(const std::vector<const std::vector<int16_t> *> &signals, unsigned channels, double level = 1.0,
                     double gain_limit = 1.0);

// The law's gain for a set of stored foci (device_mix(...).gain).
double mixer_gain(const std::vector<const std::vector<int16_t> *> &signals, unsigned channels);

// Every pair of foci at least lambda/2 apart (and, with `triples`, every
// such triple), the stored signals at rate_hz.
MultiTouchReport verify_multitouch(const CalibrationInput &in, const TransferMatrix &H,
                                   const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                   const MultiTouchOptions &options = {});

} // namespace calib::pipeline
