#include "pipeline/placement/placement.h"
#include "pipeline/signal/real_fft.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

std::vector<Point> candidate_sites(const Band &band, double spacing)
{
    if (!(spacing > 0))
        throw std::invalid_argument("candidate site spacing must be > 0");
    std::vector<Point> sites;
    const auto nx = static_cast<long>(std::floor(band.plate_x_m / spacing));
    const auto ny = static_cast<long>(std::floor(band.plate_y_m / spacing));
    // Lattice centred on the plate so a symmetric plate gets symmetric sites.
    const double ox = (band.plate_x_m - static_cast<double>(nx) * spacing) / 2;
    const double oy = (band.plate_y_m - static_cast<double>(ny) * spacing) / 2;
    for (long j = 0; j <= ny; j++)
        for (long i = 0; i <= nx; i++) {
            Point p{ox + static_cast<double>(i) * spacing, oy + static_cast<double>(j) * spacing};
            if (band.allows(p))
                sites.push_back(p);
        }
    return sites;
}

double distance_variety(const std::vector<Point> &e, double tol)
{
    std::vector<double> d;
    for (size_t i = 0; i < e.size(); i++)
        for (size_t j = i + 1; j < e.size(); j++)
            d.push_back(dist(e[i], e[j]));
    if (d.size() < 2)
        return 1.0;
    std::sort(d.begin(), d.end());
    size_t distinct = 0;
    for (size_t k = 0; k < d.size(); k++) {
        const bool near_prev = k > 0 && d[k] - d[k - 1] <= tol;
        const bool near_next = k + 1 < d.size() && d[k + 1] - d[k] <= tol;
        distinct += !near_prev && !near_next;
    }
    return static_cast<double>(distinct) / static_cast<double>(d.size());
}

std::vector<size_t> regular_pattern(const Band &band, const std::vector<Point> &sites, unsigned count)
{
    if (sites.size() < count)
        throw std::invalid_argument("fewer candidate sites than exciters");
    // Centre line of the outer ring: halfway between the frame margin and the
    // active area (or the plate centre when the ring is the whole plate).
    const double m = band.frame_margin_m;
    const double inner_x = std::max(m, band.active_area.x0_m - band.clearance_m);
    const double inner_y = std::max(m, band.active_area.y0_m - band.clearance_m);
    const double x0 = (m + inner_x) / 2, y0 = (m + inner_y) / 2;
    const double x1 = band.plate_x_m - x0, y1 = band.plate_y_m - y0;
    const double w = x1 - x0, h = y1 - y0, perimeter = 2 * (w + h);
    std::vector<size_t> chosen;
    for (unsigned k = 0; k < count; k++) {
        double s = perimeter * k / count; // start at the lower-left corner
        Point p;
        if (s < w)
            p = {x0 + s, y0};
        else if ((s -= w) < h)
            p = {x1, y0 + s};
        else if ((s -= h) < w)
            p = {x1 - s, y1};
        else
            p = {x0, y1 - (s - w)};
        size_t best = sites.size();
        double bd = std::numeric_limits<double>::infinity();
        for (size_t i = 0; i < sites.size(); i++)
            if (std::find(chosen.begin(), chosen.end(), i) == chosen.end() && dist(sites[i], p) < bd) {
                bd = dist(sites[i], p);
                best = i;
            }
        chosen.push_back(best);
    }
    return chosen;
}

// ---- contrast model ----

ContrastModel::ContrastModel(const std::vector<std::vector<std::vector<float>>> &r,
                             const std::vector<std::vector<std::vector<float>>> &h, size_t foci, size_t keep,
                             size_t half_window)
{
    rows_ = h.size();
    foci_ = foci;
    if (rows_ == 0 || foci == 0 || foci > rows_ || r.size() < foci || h[0].empty() || h[0][0].empty())
        throw std::invalid_argument("contrast model: no responses");
    if (r[0].size() != h[0].size() || r[0][0].size() != h[0][0].size())
        throw std::invalid_argument("contrast model: pulse and impulse responses differ in shape");
    if (rows_ < 2)
        throw std::invalid_argument("contrast model: needs at least one other focus or probe point");
    sites_ = h[0].size();
    const size_t len = h[0][0].size();
    keep = std::clamp<size_t>(keep, 1, len);
    const size_t all_lags = keep + len - 1; // lag from -(keep-1) to len-1
    size_t nfft = 1;
    while (nfft < all_lags)
        nfft *= 2;
    // Stored lags: first_lag .. first_lag + lags_ - 1.
    long first_lag = -static_cast<long>(keep - 1);
    lags_ = all_lags;
    if (half_window > 0) {
        first_lag = std::max(first_lag, -static_cast<long>(half_window));
        const long last_lag = std::min(static_cast<long>(len) - 1, static_cast<long>(half_window));
        lags_ = static_cast<size_t>(last_lag - first_lag + 1);
    }
    keep_ = keep;
    nfft_ = nfft;
    first_lag_ = first_lag;
    chunks_.push_back({0, rows_, std::vector<float>(sites_ * foci_ * rows_ * lags_, 0.0f)});
    judged_.assign(foci_ * rows_, 1);
    for (size_t f = 0; f < foci_; f++)
        judged_[f * rows_ + f] = 0;
    correlate(r, h, 0);
}

void ContrastModel::add_rows(const std::vector<std::vector<std::vector<float>>> &r,
                             const std::vector<std::vector<std::vector<float>>> &h)
{
    const size_t old = rows_, added = h.size() - old;
    if (h.size() <= old || h[old].size() != sites_)
        throw std::invalid_argument("contrast model: no rows to add");
    chunks_.push_back({old, added, std::vector<float>(sites_ * foci_ * added * lags_, 0.0f)});
    std::vector<char> judged(foci_ * h.size(), 1);
    for (size_t f = 0; f < foci_; f++)
        std::copy_n(&judged_[f * old], old, &judged[f * h.size()]);
    judged_ = std::move(judged);
    rows_ = h.size();
    correlate(r, h, old);
}

void ContrastModel::correlate(const std::vector<std::vector<std::vector<float>>> &r,
                              const std::vector<std::vector<std::vector<float>>> &h, size_t first_row)
{
    const size_t keep = keep_, nfft = nfft_;
    const long first_lag = first_lag_;
    // Correlations through real FFTs (FFTW), one plan per thread. A thread
    // whose plan failed still takes part in the loop (no thread may leave the
    // work-sharing) and skips its share; the failure is thrown after.
    std::string failure;
#pragma omp parallel
    {
        const std::unique_ptr<RealFft> fft = thread_fft(nfft, failure);
        const size_t bins = nfft / 2 + 1;
        std::vector<std::complex<double>> spec_full(fft ? rows_ * bins : 0), spec_kept(fft ? foci_ * bins : 0);
        const double scale = 1.0 / static_cast<double>(nfft); // FFTW's inverse is unnormalized
#pragma omp for schedule(dynamic)
        for (size_t i = 0; i < sites_; i++) {
            if (!fft)
                continue;
            double *x = fft->real();
            std::complex<double> *X = fft->spectrum();
            for (size_t g = first_row; g < rows_; g++) {
                fft->forward_padded(h[g][i].data(), h[g][i].size());
                std::copy(X, X + bins, &spec_full[g * bins]);
            }
            for (size_t f = 0; f < foci_; f++) {
                fft->forward_padded(r[f][i].data(), keep);
                std::copy(X, X + bins, &spec_kept[f * bins]);
            }
            for (size_t f = 0; f < foci_; f++)
                for (size_t g = first_row; g < rows_; g++) {
                    const std::complex<double> *kf = &spec_kept[f * bins], *fg = &spec_full[g * bins];
                    for (size_t k = 0; k < bins; k++)
                        X[k] = std::conj(kf[k]) * fg[k];
                    fft->inverse();
                    Chunk &ch = chunks_.back();
                    float *c = &ch.corr[((i * foci_ + f) * ch.rows + (g - ch.first_row)) * lags_];
                    for (size_t l = 0; l < lags_; l++) { // circular index of the lag (first_lag > -nfft)
                        const long lag = first_lag + static_cast<long>(l);
                        c[l] = static_cast<float>(
                            scale * x[static_cast<size_t>(lag < 0 ? lag + static_cast<long>(nfft) : lag)]);
                    }
                }
        }
    }
    if (!failure.empty())
        throw std::runtime_error("contrast model: " + failure);
}

void ContrastModel::State::add(size_t site, float sign)
{
    for (size_t k = 0; k < m_->chunks_.size(); k++) {
        const Chunk &ch = m_->chunks_[k];
        const float *c = &ch.corr[site * m_->foci_ * ch.rows * m_->lags_];
        std::vector<float> &y = y_[k];
        for (size_t n = 0; n < y.size(); n++)
            y[n] += sign * c[n];
    }
}

ContrastModel::Score ContrastModel::State::evaluate(size_t rows) const
{
    const ContrastModel &m = *m_;
    Score s;
    s.worst_db = std::numeric_limits<double>::infinity();
    for (size_t f = 0; f < m.foci_; f++) {
        double own = 0, other = 0;
        for (size_t k = 0; k < m.chunks_.size(); k++) {
            const Chunk &ch = m.chunks_[k];
            for (size_t r = 0; r < ch.rows && ch.first_row + r < rows; r++) {
                const size_t g = ch.first_row + r;
                const float *y = &y_[k][(f * ch.rows + r) * m.lags_];
                float peak = 0;
                for (size_t l = 0; l < m.lags_; l++)
                    peak = std::max(peak, std::abs(y[l]));
                if (g == f)
                    own = std::max(own, static_cast<double>(peak));
                else if (m.judged_[f * m.rows_ + g])
                    other = std::max(other, static_cast<double>(peak));
            }
        }
        const double db = 20 * std::log10(std::max(own, 1e-300) / std::max(other, 1e-300));
        s.per_focus_db.push_back(db);
        s.worst_db = std::min(s.worst_db, db);
    }
    return s;
}

double ContrastModel::State::trial(size_t out, size_t in, const std::function<bool(double)> &keep_going) const
{
    const ContrastModel &m = *m_;
    double worst = std::numeric_limits<double>::infinity();
    for (size_t n = 0; n < m.foci_; n++) {
        const size_t f = (lead_ + n) % m.foci_;
        double own = 0, other = 0;
        for (size_t k = 0; k < m.chunks_.size(); k++) {
            const Chunk &ch = m.chunks_[k];
            const size_t block = m.foci_ * ch.rows * m.lags_;
            const float *co = &ch.corr[out * block], *ci = &ch.corr[in * block];
            for (size_t r = 0; r < ch.rows; r++) {
                const size_t g = ch.first_row + r;
                if (g != f && !m.judged_[f * m.rows_ + g])
                    continue;
                const size_t at = (f * ch.rows + r) * m.lags_;
                const float *y = &y_[k][at], *a = co + at, *b = ci + at;
                float peak = 0;
#pragma omp simd reduction(max : peak)
                for (size_t l = 0; l < m.lags_; l++)
                    peak = std::max(peak, std::abs((y[l] - a[l]) + b[l]));
                (g == f ? own : other) = std::max(g == f ? own : other, static_cast<double>(peak));
            }
        }
        worst = std::min(worst, 20 * std::log10(std::max(own, 1e-300) / std::max(other, 1e-300)));
        if (!keep_going(worst)) {
            lead_ = f;
            return worst;
        }
    }
    return worst;
}

void ContrastModel::State::commit(size_t out, size_t in)
{
    const ContrastModel &m = *m_;
    for (size_t k = 0; k < m.chunks_.size(); k++) {
        const Chunk &ch = m.chunks_[k];
        const size_t block = m.foci_ * ch.rows * m.lags_;
        const float *a = &ch.corr[out * block], *b = &ch.corr[in * block];
        float *y = y_[k].data();
#pragma omp simd
        for (size_t n = 0; n < block; n++)
            y[n] = (y[n] - a[n]) + b[n];
    }
}

ContrastModel::Score ContrastModel::score(const std::vector<size_t> &chosen, size_t rows) const
{
    State st(*this);
    for (size_t i : chosen)
        st.add(i, 1.0f);
    return st.evaluate(rows);
}

// ---- search ----

namespace {

// Evaluator concept: double set(const std::vector<size_t>&) evaluates a new
// set; double trial(j, old_site, site, acceptable) evaluates the set with
// exciter j moved to site (it may stop early once acceptable(a bound the
// score can only fall below) is false, and return that bound); commit(j,
// old_site, site) keeps the move, reject(j, old_site, site) drops it.
// One restart: its own random stream (the seed and the restart's index), so
// the restarts run in any order and on any number of threads with one result.
template <class Evaluator>
SearchResult anneal_restart(const std::vector<Point> &sites, const SearchOptions &o, unsigned restart, Evaluator &ev)
{
    std::seed_seq seq{std::uint32_t(o.seed), std::uint32_t(o.seed >> 32), std::uint32_t(restart)};
    std::mt19937_64 rng(seq);
    auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
    auto spaced_ok = [&](const std::vector<size_t> &set, size_t skip, size_t candidate) {
        for (size_t j = 0; j < set.size(); j++)
            if (j != skip && dist(sites[set[j]], sites[candidate]) < o.min_spacing_m)
                return false;
        return true;
    };
    SearchResult best;
    best.objective = -std::numeric_limits<double>::infinity();
    // Random start: greedy random insertion with the spacing constraint.
    std::vector<size_t> set;
    if (restart == 0 && o.first_start.size() == o.count) {
        for (size_t c : o.first_start)
            if (c < sites.size() && std::find(set.begin(), set.end(), c) == set.end() && spaced_ok(set, set.size(), c))
                set.push_back(c);
        if (set.size() != o.count)
            set.clear(); // not a valid start: random like the others
    }
    for (unsigned tries = 0; set.size() < o.count && tries < 100 * o.count * (sites.size() + 1); tries++) {
        const size_t c = rng() % sites.size();
        if (std::find(set.begin(), set.end(), c) == set.end() && spaced_ok(set, set.size(), c))
            set.push_back(c);
    }
    if (set.size() < o.count)
        throw std::invalid_argument("the border band cannot hold " + std::to_string(o.count) + " exciters at least " +
                                    std::to_string(o.min_spacing_m) + " m apart");
    double cur = ev.set(set);
    best.evaluations++;
    best.objective = cur;
    best.chosen = set;
    const double t0 = o.temperature_start, t1 = o.temperature_end;
    for (unsigned it = 0; it < o.iterations; it++) {
        const double temp = t0 * std::pow(t1 / t0, static_cast<double>(it) / std::max(1u, o.iterations - 1));
        const size_t j = rng() % set.size();
        size_t cand;
        if (uniform() < 0.75) { // local move
            const Point c = sites[set[j]];
            const double ang = 2 * std::numbers::pi * uniform(), rad = o.local_radius_m * uniform();
            const Point target{c.x_m + rad * std::cos(ang), c.y_m + rad * std::sin(ang)};
            cand = set[j];
            double bd = std::numeric_limits<double>::infinity();
            for (size_t i = 0; i < sites.size(); i++)
                if (const double di = dist(sites[i], target); di < bd) {
                    bd = di;
                    cand = i;
                }
        } else {
            cand = rng() % sites.size();
        }
        if (cand == set[j] || std::find(set.begin(), set.end(), cand) != set.end() || !spaced_ok(set, j, cand))
            continue;
        const size_t old = set[j];
        set[j] = cand;
        // Metropolis: a better set always, a worse one with probability
        // exp(difference / temperature). The uniform is drawn the first time
        // the test meets a worse score, so the random stream is the one an
        // evaluation of the whole score would take.
        bool drawn = false;
        double u = 0;
        auto acceptable = [&](double next) {
            if (next >= cur)
                return true;
            if (!drawn) {
                u = uniform();
                drawn = true;
            }
            return u < std::exp((next - cur) / temp);
        };
        const double next = ev.trial(j, old, cand, acceptable);
        best.evaluations++;
        if (acceptable(next)) {
            ev.commit(j, old, cand);
            cur = next;
            if (cur > best.objective) {
                best.objective = cur;
                best.chosen = set;
            }
        } else {
            ev.reject(j, old, cand);
            set[j] = old;
        }
    }
    return best;
}

// The restarts in parallel, each with its own evaluator (a copy of `ev`);
// the best objective wins, the lowest restart on a tie.
template <class Evaluator>
SearchResult anneal(const std::vector<Point> &sites, const SearchOptions &o, const Evaluator &ev)
{
    if (o.count == 0)
        throw std::invalid_argument("exciter count must be >= 1");
    std::vector<SearchResult> results(o.restarts);
    std::string failure;
#pragma omp parallel for schedule(dynamic)
    for (unsigned r = 0; r < o.restarts; r++) {
        try {
            Evaluator own = ev;
            results[r] = anneal_restart(sites, o, r, own);
        } catch (const std::exception &ex) {
#pragma omp critical
            if (failure.empty())
                failure = ex.what();
        }
    }
    if (!failure.empty())
        throw std::invalid_argument(failure);
    SearchResult best;
    best.objective = -std::numeric_limits<double>::infinity();
    for (const SearchResult &r : results) {
        best.evaluations += r.evaluations;
        if (r.objective > best.objective) {
            best.objective = r.objective;
            best.chosen = r.chosen;
        }
    }
    return best;
}

struct FunctionEvaluator {
    const Objective &f;
    std::vector<size_t> chosen;
    double set(const std::vector<size_t> &s)
    {
        chosen = s;
        return f(chosen);
    }
    template <class Acceptable>
    double trial(size_t j, size_t, size_t cand, const Acceptable &)
    {
        chosen[j] = cand;
        return f(chosen);
    }
    void commit(size_t, size_t, size_t) {}
    void reject(size_t j, size_t old, size_t) { chosen[j] = old; }
};

struct ContrastEvaluator {
    const ContrastModel &m;
    ContrastModel::State st{m};
    double set(const std::vector<size_t> &s)
    {
        st = ContrastModel::State(m);
        for (size_t i : s)
            st.add(i, 1.0f);
        return st.evaluate().worst_db;
    }
    template <class Acceptable>
    double trial(size_t, size_t old, size_t cand, const Acceptable &acceptable)
    {
        return st.trial(old, cand, std::cref(acceptable));
    }
    void commit(size_t, size_t old, size_t cand) { st.commit(old, cand); }
    void reject(size_t, size_t, size_t) {}
};

} // namespace

SearchResult search_placement(const std::vector<Point> &sites, const SearchOptions &o, const Objective &objective)
{
    return anneal(sites, o, FunctionEvaluator{objective, {}});
}

SearchResult search_placement_contrast(const std::vector<Point> &sites, const SearchOptions &o,
                                       const ContrastModel &model)
{
    if (model.sites() != sites.size())
        throw std::invalid_argument("contrast model and candidate sites differ in count");
    return anneal(sites, o, ContrastEvaluator{model});
}

} // namespace calib::pipeline
