// A calibration on an emulator (docs/closing-the-loop.md "Emulators"): a space-filling
// design over a box, a Gaussian process per observed quantity, the fit on the emulators, and
// runs of the simulator only where they decide something: at the emulator's optimum (the
// confirmation) and where the emulator is unsure near it, q points at a time.
//
// Independent of the engine: the simulator is a function of points in the unit box, so the
// same code calibrates the particle model (drivers/loop/Calibration.cpp) and the analytic
// functions of the tests.
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "drivers/loop/Emulator.hpp"

namespace tamp::loop {

// The simulator: for each point of the batch (unit box), its outputs (one per observation),
// or an empty vector for a failed run (NaN, time-out): a failed point, never a crash.
using UnitSimulator = std::function<std::vector<Eigen::VectorXd>(const std::vector<Eigen::VectorXd>&)>;

struct EmulatedFitOptions {
  int points_per_parameter = 10;  // the initial design: about 10 runs per input (Loeppky et al. 2009)
  int batch = 2;                  // q points per sequential round (independent of the workers: the
                                  // answer is the same whatever their number)
  int max_rounds = 4;             // sequential rounds at most
  double confirm_z = 3.0;         // a run confirms the emulator when every output is within this many
                                  // predictive standard deviations of its prediction
  double max_latent_share = 1.0;  // converged: at the optimum, every output's emulator variance is at
                                  // most this share of the variance it is compared with (sigma^2 + nugget)
  std::uint64_t seed = 1;         // the design's seed
  // Two fidelities, screening: no run of the full simulator. The fit is the full one's as the
  // pairs already run see it (cheap emulators plus their discrepancy), and each round's
  // optimum is checked by a cheap run against the cheap emulators. A diagnosis screens every
  // candidate so, and spends full runs only on those that can win (docs/closing-the-loop.md).
  bool screen = false;
  // A nested model's face (coordinate, fixed unit value): its fit on the final emulators is
  // reported too (EmulatedFit::nested), e.g. the current model as a candidate's effect off.
  std::vector<std::pair<int, double>> nested_face;
};

// The fit of the emulators at a point: per output the prediction's variance v (the smooth
// response's uncertainty and the nugget, the simulator's own jitter) added to the
// observation's sigma^2. chi2 = sum r^2 / (sigma^2 + v); the deviance adds sum ln(1 + v /
// sigma^2), the normalisation of the Gaussian likelihood (-2 ln L up to a constant), so that
// an uncertain emulator is not a better fit: it is chi2 itself when v = 0.
// Two fidelities (Kennedy & O'Hagan 2000, their autoregressive model with the coefficient 1):
// the emulators learn a cheap simulator; the full one is the cheap one plus a discrepancy per
// output, learnt from pairs of runs of both at the same point. With few pairs (fewer than d +
// 3) the discrepancy is a constant: the pairs' mean, its variance their scatter s^2 (1 + 1/p)
// (one pair: s^2 twice the cheap emulator's nugget, the jitter of two runs). With more, it is
// linear in x by least squares, its variance s^2 (1 + h^T (H^T H)^-1 h) at x, h = (1, x).
struct DiscrepancyPair {
  Eigen::VectorXd x, cheap, full;
};
struct Discrepancy {
  int pairs = 0;
  bool linear = false;
  Eigen::MatrixXd coef;   // outputs x (1 + d): the mean is coef h(x)
  Eigen::VectorXd s2;     // per output, the scatter about that mean
  Eigen::MatrixXd HtHi;   // (H^T H)^-1 of the pairs' h
  double mean(long i, const Eigen::VectorXd& x) const;
  double var(long i, const Eigen::VectorXd& x) const;
};
Discrepancy learn_discrepancy(const std::vector<DiscrepancyPair>& pairs, const std::vector<GaussianProcess>& cheap);

struct EmulatedDeviance {
  double chi2 = 0, deviance = 0;
  double latent_share = 0;  // the largest v_latent / (sigma^2 + nugget) over the outputs
};
// With `dz`, of the full simulator: the emulators' mean plus the discrepancy, their variance
// plus its.
EmulatedDeviance emulated_deviance(const std::vector<GaussianProcess>& em, const Eigen::VectorXd& targets,
                                   const Eigen::VectorXd& sigmas, const Eigen::VectorXd& x,
                                   const Discrepancy* dz = nullptr);

// What the fit found, and how far the emulator is to be trusted.
struct EmulatedFit {
  Eigen::VectorXd x;              // the fitted point (unit box): the emulators' optimum, last confirmed
  EmulatedDeviance predicted;     // the final emulators there
  EmulatedDeviance nested;        // the nested model's best on the final emulators (nested_face)
  Eigen::VectorXd nested_x;
  Eigen::VectorXd mean, sd;       // per output: the final emulators' mean and predictive sd at x
  Eigen::VectorXd outputs;        // the confirmation run's outputs there (a real run)
  double run_chi2 = 0;            // its chi2 with the observations' sigma alone
  bool confirmed = false;         // the run agreed with the prediction (every output within confirm_z)
  bool converged = false;         // and the emulators' own uncertainty there is small (max_latent_share)
  double worst_z = 0;             // the largest |output - prediction| / sd of the confirmation
  int runs = 0;                   // simulator runs (design + rounds), failed ones included
  int failed = 0;
  int design_points = 0;          // the initial design's new points
  int prior_points = 0;           // earlier runs that joined it
  int rounds = 0;                 // sequential rounds
  std::vector<double> round_predicted, round_confirmed;  // per round: emulated chi2 and the run's at the optimum
  Eigen::MatrixXd cov;            // linearised covariance of x (unit box) from the emulators' gradients
  // Leave-one-out per output, in units of the observation's sigma: RMS error, and the RMS
  // of the standardised errors (about 1 when the emulator states its uncertainty honestly).
  Eigen::VectorXd loo_rmse_sigma, loo_z_rms;
  std::vector<GaussianProcess> emulators;  // the final emulators, one per output
  // Two fidelities: the runs of the full simulator (one per round, at the optimum; the
  // outputs and run_chi2 above are its), and the discrepancy learnt.
  int full_runs = 0;
  bool screened = false;          // fitted with EmulatedFitOptions::screen: confirmed by cheap runs only
  Discrepancy discrepancy;
};

// Fits `targets` (with `sigmas`) over the d-dimensional unit box. `prior`: points run
// already, with their outputs (earlier fits' runs in this box); they join the design, which
// adds max(points_per_parameter d - prior, points_per_parameter u, 2 d) new points, u the
// inputs the prior points leave unexplored (all at one value: an effect never tried).
// `full`, when given, is the full simulator and `simulate` a cheap one: the design and the
// exploration run cheap, each round's optimum runs on both (a pair), and the fit, its
// confirmation and its deviance are the full simulator's (cheap emulators plus the
// discrepancy). `prior_pairs`: pairs run already.
EmulatedFit emulated_fit(const UnitSimulator& simulate, const Eigen::VectorXd& targets, const Eigen::VectorXd& sigmas,
                         int d, const EmulatedFitOptions& opt,
                         const std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>>& prior = {},
                         const UnitSimulator* full = nullptr, const std::vector<DiscrepancyPair>& prior_pairs = {});

}  // namespace tamp::loop
