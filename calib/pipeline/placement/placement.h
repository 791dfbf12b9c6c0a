// Exciter placement in the border band: candidate sites, the seed's criterion
// (variety of inter-exciter distances), the focusing contrast predicted from
// simulated responses by reciprocity, and a seeded randomized search
// (random restarts + simulated annealing with local moves).
#pragma once
#include "pipeline/data/geometry.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <functional>
#include <vector>

namespace calib::pipeline {

// Sites on a square lattice of the given spacing, inside the band.
std::vector<Point> candidate_sites(const Band &band, double spacing_m);

// Seed criterion: the fraction of the n(n-1)/2 inter-exciter distances that
// differ from every other one by more than tolerance_m (1 = all distinct;
// symmetric patterns repeat distances and score low).
double distance_variety(const std::vector<Point> &exciters, double tolerance_m);

// The regular symmetric pattern: `count` points equally spaced along the
// centre line of the band's outer ring (corners and edge midpoints for 8 on a
// square plate), each snapped to the nearest free candidate site.
std::vector<size_t> regular_pattern(const Band &band, const std::vector<Point> &sites, unsigned count);

// Predicted focusing contrast from reciprocity. responses[g][i] is the
// displacement at candidate site i while the pulse (or an impulse) is emitted at point g
// (the first `foci` rows are foci, any further rows are probe points where
// the field must stay small). Driving focus f's time-reversed signals (the
// first `keep` samples reversed) from set E gives at point g
//     y_fg(lag) = sum_{i in E} sum_u r_fi(u) r_gi(u + lag),
// a sum of per-site cross-correlations that are computed once (FFT).
// Contrast of f = max|y_ff| / max_{g != f} max|y_fg|.
class ContrastModel {
  public:
    // half_window > 0 keeps only lags within +-half_window samples of the
    // focus instant (the field when the focus forms, as in the seed's Fig. 4);
    // 0 keeps every lag (the field at all times, as in Fig. 8).
    ContrastModel(const std::vector<std::vector<std::vector<float>>> &responses, size_t foci, size_t keep,
                  size_t half_window = 0)
        : ContrastModel(responses, responses, foci, keep, half_window)
    {}
    // The exact form: drive signals from the pulse responses r, the field from
    // the impulse responses h (y_fg = sum_i rev(r_fi) * h_gi is then the field
    // the exciters produce at g, up to resampling and quantization).
    ContrastModel(const std::vector<std::vector<std::vector<float>>> &pulse_responses,
                  const std::vector<std::vector<std::vector<float>>> &impulse_responses, size_t foci, size_t keep,
                  size_t half_window = 0);
    size_t sites() const { return sites_; }
    size_t foci() const { return foci_; }
    size_t rows() const { return rows_; }
    // Row g no longer counts against focus f (a probe point within lambda/2
    // of it: inside its own spot). By default every row but f's own counts.
    void ignore(size_t f, size_t g) { judged_[f * rows_ + g] = 0; }
    // More rows (probe points): r and h as given to the constructor with the
    // new emitters' responses appended; only the new rows are correlated.
    void add_rows(const std::vector<std::vector<std::vector<float>>> &pulse_responses,
                  const std::vector<std::vector<std::vector<float>>> &impulse_responses);
    size_t bytes() const
    {
        size_t b = 0;
        for (const Chunk &c : chunks_)
            b += c.corr.size() * sizeof(float);
        return b;
    }
    // Bytes of one more row.
    size_t row_bytes() const { return sites_ * foci_ * lags_ * sizeof(float); }

    struct Score {
        double worst_db = 0; // min over foci of 20 log10(contrast)
        std::vector<double> per_focus_db;
    };
    // Over the first `rows` rows only (the foci and the first probes).
    Score score(const std::vector<size_t> &chosen, size_t rows = SIZE_MAX) const;

    // Running sum for a set, updated in O(foci * rows * lags) per exchanged site.
    class State {
      public:
        explicit State(const ContrastModel &m) : m_(&m)
        {
            for (const Chunk &c : m.chunks_)
                y_.emplace_back(m.foci_ * c.rows * m.lags_, 0.0f);
        }
        void add(size_t site, float sign);
        Score evaluate(size_t rows = SIZE_MAX) const;
        // The worst_db evaluate() would return with site `out` exchanged for
        // `in`, the sums left as they are. Foci are taken one at a time and
        // the trial stops as soon as keep_going(the worst so far) is false:
        // the worst can only fall as foci are added, so a caller whose test
        // is monotone in the score (the annealer's acceptance) decides on the
        // value returned exactly as on the full one. Reads the sums and the
        // two sites' correlations once, writes nothing.
        double trial(size_t out, size_t in, const std::function<bool(double)> &keep_going) const;
        // The exchange made: add(out, -1) then add(in, +1) in one pass,
        // element by element with trial's arithmetic (so the floats trial saw).
        void commit(size_t out, size_t in);

      private:
        const ContrastModel *m_;
        std::vector<std::vector<float>> y_; // per chunk, [f][g][lag]
        mutable size_t lead_ = 0;           // the focus that stopped the last trial: tried first
    };

  private:
    void correlate(const std::vector<std::vector<std::vector<float>>> &r,
                   const std::vector<std::vector<std::vector<float>>> &h, size_t first_row);
    size_t sites_, rows_, foci_, lags_;
    size_t keep_ = 0, nfft_ = 0;
    long first_lag_ = 0;
    // The rows in chunks, as they were added (the foci and the plan's probes
    // first): adding rows appends a chunk, nothing is copied.
    struct Chunk {
        size_t first_row = 0, rows = 0;
        std::vector<float> corr; // [site][f][g - first_row][lag]
    };
    std::vector<Chunk> chunks_;
    std::vector<char> judged_; // [f][g]: row g counts against focus f
};

struct SearchOptions {
    unsigned count = 8;
    double min_spacing_m = 0.03;
    uint64_t seed = 1;
    unsigned restarts = 8;
    unsigned iterations = 1500;  // annealing moves per restart
    double local_radius_m = 0.1; // most moves stay within this distance
    // Annealing temperature in objective units (dB for the contrast objective),
    // lowered geometrically over each restart.
    double temperature_start = 1.0, temperature_end = 0.01;
    // If valid, the first restart starts here (e.g. the regular pattern), so
    // the result is never worse than it.
    std::vector<size_t> first_start;
};

struct SearchResult {
    std::vector<size_t> chosen; // indices into the candidate sites
    double objective = 0;
    unsigned evaluations = 0;
};

// Maximizes objective(chosen) over sets of `count` sites at least
// min_spacing apart. The restarts run in parallel (OpenMP), each with its own
// random stream drawn from the seed and its index: the result depends on the
// seed, not on the thread count. `objective` is called from several threads
// at once. Throws std::invalid_argument when the band cannot hold `count`
// exciters at that spacing.
using Objective = std::function<double(const std::vector<size_t> &chosen)>;
SearchResult search_placement(const std::vector<Point> &sites, const SearchOptions &options,
                              const Objective &objective);

// Same search with the contrast model, using its incremental state.
SearchResult search_placement_contrast(const std::vector<Point> &sites, const SearchOptions &options,
                                       const ContrastModel &model);

} // namespace calib::pipeline
