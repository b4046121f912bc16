// The loop's statistical model of the simulator (docs/closing-the-loop.md "Emulators"):
// space-filling designs and a Gaussian-process emulator (universal kriging) of one output
// over the unit box [0, 1]^d.
//
// Why our own and not OpenTURNS: the emulator is ~300 lines on Eigen, which the engine links
// already; OpenTURNS (Debian libopenturns-dev 1.20) would add a 40 MB library and its
// dependency tree to the bootstrap for the same three pieces (Latin hypercube, Kriging with
// a linear trend and an anisotropic Matern kernel, restricted maximum likelihood).
// Sources: Sacks, Welch, Mitchell & Wynn (1989), Statistical Science 4:409 (kriging of
// computer experiments); Rasmussen & Williams (2006) ch. 2 and 5 (prediction, Matern 5/2,
// likelihood); Santner, Williams & Notz (2003) ch. 3-4 (universal kriging variance, REML).
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace tamp::loop {

// A maximin Latin hypercube of n points in [0, 1]^d: of `tries` random Latin hypercubes
// (cell centres jittered, seeded: the same seed gives the same design) the one whose
// smallest pairwise distance is largest (Morris & Mitchell 1995). Rows are points.
Eigen::MatrixXd maximin_lhs(int n, int d, std::uint64_t seed, int tries = 200);

// A Gaussian process y(x) = h(x)^T beta + Z(x) + e: linear trend h = (1, x_1..x_d) (a
// constant alone when there are fewer than 2 (d + 1) points), Z a stationary process of
// variance s2 with an anisotropic Matern 5/2 correlation (length scales l_j), e a nugget of
// variance g s2 (the run-to-run jitter of a particle model: its small jumps). beta by
// generalised least squares; s2, l, g by restricted maximum likelihood, multi-start
// Nelder-Mead in log coordinates within l in [0.03, 30], g in [1e-8, 1].
class GaussianProcess {
 public:
  void fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
  // Prediction at x: the mean, the variance of the smooth response (the emulator's own
  // uncertainty, with that of beta), and the nugget variance (what a run adds to it).
  struct Prediction {
    double mean = 0, variance = 0, nugget = 0;
  };
  Prediction predict(const Eigen::VectorXd& x) const;
  // The same process conditioned on one more point, hyper-parameters kept (the "kriging
  // believer" of a batch: a point chosen but not yet run, taken at its predicted mean).
  GaussianProcess with_point(const Eigen::VectorXd& x, double y) const;
  // Leave-one-out with the fitted hyper-parameters: per design point, the prediction from
  // the others (mean, and the standard deviation of a run there: variance + nugget).
  struct LeaveOneOut {
    Eigen::VectorXd mean, sd;
  };
  LeaveOneOut leave_one_out() const;
  int points() const { return static_cast<int>(X_.rows()); }
  int dims() const { return static_cast<int>(X_.cols()); }
  const Eigen::VectorXd& length_scales() const { return ell_; }
  double nugget_ratio() const { return g_; }
  double nugget_variance() const { return g_ * s2_ * scale_ * scale_; }
  double process_variance() const { return s2_ * scale_ * scale_; }
  const Eigen::MatrixXd& inputs() const { return X_; }
  const Eigen::VectorXd& outputs() const { return y_; }

 private:
  double neg_log_likelihood(const Eigen::VectorXd& theta) const;  // REML, theta = (log l, log g)
  void factorise();  // R, its Cholesky, beta, s2 for the current hyper-parameters
  Eigen::VectorXd trend(const Eigen::VectorXd& x) const;
  double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const;

  Eigen::MatrixXd X_;
  Eigen::VectorXd y_;               // as given
  double centre_ = 0, scale_ = 1;   // y standardised for the fit
  Eigen::VectorXd ys_;              // standardised
  Eigen::VectorXd ell_;
  double g_ = 1e-6, s2_ = 1;
  bool linear_trend_ = true;
  // factorisation at the fitted hyper-parameters
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::MatrixXd H_;               // trend basis at the design, n x p
  Eigen::MatrixXd RiH_;             // R^-1 H
  Eigen::LDLT<Eigen::MatrixXd> HtRiH_;
  Eigen::VectorXd beta_, alpha_;    // alpha = R^-1 (ys - H beta)
};

// Nelder-Mead on f over R^m from x0 with first steps `step` (Lagarias et al. 1998
// coefficients), at most `max_evals` evaluations; returns the best point. Used for the
// hyper-parameters and for searches on the emulator (cheap functions only).
Eigen::VectorXd nelder_mead(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x0,
                            double step, int max_evals, double* fmin = nullptr);

}  // namespace tamp::loop
