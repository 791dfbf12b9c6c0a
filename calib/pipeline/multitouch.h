// Several fingers at once, verified from H: the device superposes the stored
// single-focus signals of the touched foci with the firmware's energy
// normalisation (firmware/src/mixer.h): y = g sum_{f in S} s_f with
//   g = min(sqrt(E_ref / E_sum), 32767 / P(S), 1),
// E_ref the mean energy of the selected foci alone, E_sum the energy of the
// unscaled sum (from the Gram matrix of the stored counts), P(S) the
// firmware's block bound of the sum's peak (64-frame blocks) and 1 the
// default gain limit. The mix is played through H (playback.h) and read at
// every time: each touched focus must reach the threshold, and nothing in
// the active area farther than lambda/2 from every touched focus may.
#pragma once
#include "pipeline/placement.h"
#include "pipeline/transfer.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct CalibrationInput;

struct MultiTouchCase {
    std::vector<std::size_t> foci;      // indices into the scene's foci
    double gain = 0;                    // the firmware's g
    double min_focus_peak_m = 0;        // the weakest touched focus
    double max_elsewhere_m = 0;         // largest |w| beyond lambda/2 of every touched focus, all times
    Point elsewhere_at;
    // min(weakest focus - threshold, threshold - max elsewhere): > 0 when ok.
    double margin_m = 0;
    bool ok = false;                    // every touched focus crosses, nothing else does
};

struct MultiTouchReport {
    std::vector<MultiTouchCase> cases;
    std::size_t worst = 0;              // least margin_m
    std::size_t failing = 0;
};

// The firmware's gain for a set of stored foci ([n][c] int16 counts).
double mixer_gain(const std::vector<const std::vector<int16_t> *> &signals, unsigned channels);

// Every pair of foci at least lambda/2 apart (and, with `triples`, every
// such triple), the stored signals at rate_hz.
MultiTouchReport verify_multitouch(const CalibrationInput &in, const TransferMatrix &H,
                                   const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                   bool triples = false);

}  // namespace calib::pipeline
