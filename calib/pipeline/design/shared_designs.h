// The designs of a scene's foci that share what does not depend on the
// focus (inverse_filter.h, inverse_filter_designs). Internal to
// pipeline/design/.
#pragma once
#include "pipeline/design/inverse_filter.h"
#include "pipeline/transfer/playback.h"

#include <Eigen/Dense>

#include <cstddef>
#include <memory>
#include <vector>

namespace calib::pipeline {

// What the designs of all foci share. A focus's normal matrix is
//   sum_{p in Q_f} w_p G_p + W_f G_f,
// G_p the block Toeplitz matrix of point p's cross-correlations, which does
// not depend on the focus nor on the weights: so each point's correlations
// (summed over the plates) are computed once, and a design's R (see
// summed_correlations) is their weighted sum, R = Rp w, w zero at the points
// the focus does not weigh. Likewise one playback serves every focus's
// minimax refinement, and each design is solved without forming G
// (toeplitz_design). The designs are those of minimax_design to round-off
// (the sums taken in another order, another backward-stable solve);
// test_inverse_filter_shared checks it.
class SharedDesigns {
  public:
    SharedDesigns(const Plates &plates, const std::vector<std::size_t> &points, std::size_t drive_samples);
    // minimax_design(plates, p, o), p's points among those served.
    InverseFilterDesign minimax(InverseFilterProblem p, const InverseFilterOptions &o) const;

  private:
    Eigen::Index column(std::size_t point) const;

    const Plates &plates_;
    std::size_t J_;
    std::vector<std::ptrdiff_t> column_;          // per point of H, its column of Rp (-1: not served)
    Eigen::MatrixXd Rp_;                          // [pair, lag][point], as R with that point alone at weight 1
    std::vector<std::unique_ptr<Playback>> play_; // per plate, the served points
};

} // namespace calib::pipeline
