// Per-exciter gains of a time-reversal design, judged by the verdict.
//
// Time reversal gives every exciter its own reversed recording at one gain.
// The field a focus's drive makes at a point x and time t is then a sum of
// the exciters' contributions, g(x, t) = sum_c w_c g_c(x, t), linear in the
// gains w. The verdict asks that nothing beyond lambda/2 in the active area
// reach the threshold at any time while the focus does; so the gains that
// serve it best minimise the largest |g(x, t)| over those points and times
// with the focal value held:
//     minimise max_i |G_i . w|  subject to  a . w = a . 1,
// G_i the contributions at one (x, t), a the contributions at the focus at
// its focal instant. Each exciter still plays its time-reversed recording;
// only its level (and, where that serves, its polarity) changes. Equal gains
// are the seed's time reversal and the solver's first iterate, so the result
// is never worse on the rows it is given.
//
// The solver is Lawson's algorithm (iteratively reweighted least squares,
// whose weights converge to the minimax solution's dual: C. L. Lawson,
// "Contributions to the theory of linear least maximum approximation", PhD
// thesis, UCLA 1961; J. R. Rice and K. H. Usow, "The Lawson algorithm and
// extensions", Math. Comp. 22 (1968) 118-127). With 8 unknowns each step is
// an 8 x 8 solve. It runs on an active set: the rows within a factor 2 of the
// equal gains' largest, then those the result lets rise within 80 % of its
// own largest, until no row does (a few rounds); rows whose Lawson weight
// falls below 1e-9 of the largest leave the iterations. The result is the
// iterate with the least largest residual over every row.
#pragma once
#include <Eigen/Dense>

#include <cstddef>
#include <vector>

namespace calib::pipeline {

struct ExciterGains {
    std::vector<double> gain; // per exciter, a . gain = a . 1 (the equal design's focal value)
    double equal_ratio = 0;   // max_i |G_i . 1| / (a . 1): the equal gains' largest ghost over the focus
    double ratio = 0;         // the same for `gain` (<= equal_ratio)
};

// G: one column per row of the problem (exciters x rows, contiguous per row);
// a: the contributions at the focus. Equal gains when a . 1 is not a finite
// non-zero number or G has no columns (nothing to improve against).
ExciterGains minimax_gains(const Eigen::MatrixXf &G, const Eigen::VectorXd &a, unsigned iterations = 150);

} // namespace calib::pipeline
