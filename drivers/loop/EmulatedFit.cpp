#include "drivers/loop/EmulatedFit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace tamp::loop {

namespace {
Eigen::VectorXd clamp01(const Eigen::VectorXd& x) { return x.cwiseMax(0.0).cwiseMin(1.0); }

double chi2_of(const Eigen::VectorXd& y, const Eigen::VectorXd& t, const Eigen::VectorXd& s) {
  return (y - t).cwiseQuotient(s).squaredNorm();
}

// The lower confidence bound of a run's chi2 at x (mean - 2 sd, the smooth response's
// uncertainty only: the nugget is not reduced by running there): the batch's exploration
// criterion (GP-UCB, Srinivas et al. 2010), each pick taken as believed (Ginsbourger et al. 2010).
double chi2_lcb(const std::vector<GaussianProcess>& em, const Eigen::VectorXd& t, const Eigen::VectorXd& s,
                const Eigen::VectorXd& x, const Discrepancy* dz) {
  double mean = 0, var = 0;
  for (size_t i = 0; i < em.size(); ++i) {
    auto p = em[i].predict(x);
    if (dz && dz->pairs > 0) p.mean += dz->mean(static_cast<long>(i), x);
    const double s2 = s(static_cast<long>(i)) * s(static_cast<long>(i));
    const double r = p.mean - t(static_cast<long>(i));
    mean += (r * r + p.variance) / s2;
    var += (4 * r * r * p.variance + 2 * p.variance * p.variance) / (s2 * s2);
  }
  return mean - 2.0 * std::sqrt(var);
}

// The minimum of f over the unit box: Nelder-Mead from each start, the box kept by a
// penalty on the clamped point.
Eigen::VectorXd box_minimum(const std::function<double(const Eigen::VectorXd&)>& f, const std::vector<Eigen::VectorXd>& starts,
                            double* fbest) {
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd xb = starts.front();
  auto g = [&](const Eigen::VectorXd& x) {
    const Eigen::VectorXd c = clamp01(x);
    return f(c) + 1e3 * (x - c).squaredNorm();
  };
  for (const auto& x0 : starts) {
    double v = 0;
    const Eigen::VectorXd x = clamp01(nelder_mead(g, x0, 0.08, 150 + 60 * static_cast<int>(x0.size()), &v));
    v = f(x);
    if (v < best) {
      best = v;
      xb = x;
    }
  }
  if (fbest) *fbest = best;
  return xb;
}
}  // namespace

double Discrepancy::mean(long i, const Eigen::VectorXd& x) const {
  if (pairs == 0) return 0.0;
  if (!linear) return coef(i, 0);
  return coef(i, 0) + coef.row(i).tail(x.size()).dot(x);
}

double Discrepancy::var(long i, const Eigen::VectorXd& x) const {
  if (pairs == 0) return 0.0;
  if (!linear) return s2(i) * (1.0 + 1.0 / pairs);
  Eigen::VectorXd h(x.size() + 1);
  h(0) = 1.0;
  h.tail(x.size()) = x;
  return s2(i) * (1.0 + h.dot(HtHi * h));
}

Discrepancy learn_discrepancy(const std::vector<DiscrepancyPair>& pairs, const std::vector<GaussianProcess>& cheap) {
  const long m = static_cast<long>(cheap.size());
  Discrepancy dz;
  dz.pairs = static_cast<int>(pairs.size());
  if (pairs.empty()) return dz;
  const long d = pairs.front().x.size(), p = static_cast<long>(pairs.size());
  dz.linear = p >= d + 3;
  const long q = dz.linear ? d + 1 : 1;
  Eigen::MatrixXd H(p, q);
  Eigen::MatrixXd D(p, m);
  for (long k = 0; k < p; ++k) {
    H(k, 0) = 1.0;
    if (dz.linear) H.row(k).tail(d) = pairs[static_cast<size_t>(k)].x.transpose();
    D.row(k) = (pairs[static_cast<size_t>(k)].full - pairs[static_cast<size_t>(k)].cheap).transpose();
  }
  dz.HtHi = (H.transpose() * H + 1e-10 * Eigen::MatrixXd::Identity(q, q)).inverse();
  dz.coef = (dz.HtHi * H.transpose() * D).transpose();  // m x q
  dz.s2.resize(m);
  for (long i = 0; i < m; ++i) {
    if (p > q) {
      dz.s2(i) = (D.col(i) - H * dz.coef.row(i).transpose()).squaredNorm() / static_cast<double>(p - q);
    } else {
      dz.s2(i) = 2.0 * cheap[static_cast<size_t>(i)].nugget_variance();
    }
  }
  return dz;
}

EmulatedDeviance emulated_deviance(const std::vector<GaussianProcess>& em, const Eigen::VectorXd& t,
                                   const Eigen::VectorXd& s, const Eigen::VectorXd& x, const Discrepancy* dz) {
  EmulatedDeviance d;
  for (size_t i = 0; i < em.size(); ++i) {
    auto p = em[i].predict(x);
    double dvar = 0;  // the discrepancy's variance: like the emulator's own, more runs (pairs) reduce it
    if (dz && dz->pairs > 0) {
      p.mean += dz->mean(static_cast<long>(i), x);
      dvar = dz->var(static_cast<long>(i), x);
    }
    const double s2 = s(static_cast<long>(i)) * s(static_cast<long>(i));
    const double v = p.variance + p.nugget + dvar;
    const double r = p.mean - t(static_cast<long>(i));
    d.chi2 += r * r / (s2 + v);
    d.deviance += r * r / (s2 + v) + std::log1p(v / s2);
    d.latent_share = std::max(d.latent_share, (p.variance + dvar) / (s2 + p.nugget));
  }
  return d;
}

EmulatedFit emulated_fit(const UnitSimulator& simulate, const Eigen::VectorXd& targets, const Eigen::VectorXd& sigmas,
                         int d, const EmulatedFitOptions& opt,
                         const std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>>& prior, const UnitSimulator* full,
                         const std::vector<DiscrepancyPair>& prior_pairs) {
  const long m = targets.size();
  EmulatedFit fit;
  std::vector<DiscrepancyPair> pairs = prior_pairs;
  Discrepancy dz;
  const Discrepancy* dzp = full ? &dz : nullptr;
  auto ok_out = [&](const Eigen::VectorXd& y) { return y.size() == m && y.allFinite(); };
  std::vector<Eigen::VectorXd> X;  // successful runs
  std::vector<Eigen::VectorXd> Y;
  for (const auto& [x, y] : prior) {
    X.push_back(clamp01(x));
    Y.push_back(y);
  }
  fit.prior_points = static_cast<int>(prior.size());
  auto run = [&](const std::vector<Eigen::VectorXd>& pts) {
    const auto out = simulate(pts);
    fit.runs += static_cast<int>(pts.size());
    for (size_t k = 0; k < pts.size(); ++k) {
      const bool ok = out[k].size() == m && out[k].allFinite();
      if (!ok) {
        ++fit.failed;
        continue;
      }
      X.push_back(pts[k]);
      Y.push_back(out[k]);
    }
    return out;
  };
  // the initial design: a maximin Latin hypercube of the points the earlier runs leave to do
  int unexplored = d;
  if (!prior.empty()) {
    unexplored = 0;
    for (int j = 0; j < d; ++j) {
      double lo = 1, hi = 0;
      for (const auto& x : X) {
        lo = std::min(lo, x(j));
        hi = std::max(hi, x(j));
      }
      if (hi - lo < 1e-9) ++unexplored;
    }
  }
  const int n0 = std::max({opt.points_per_parameter * d - fit.prior_points, opt.points_per_parameter * unexplored, 2 * d});
  const Eigen::MatrixXd D = maximin_lhs(n0, d, opt.seed);
  std::vector<Eigen::VectorXd> design;
  for (long i = 0; i < D.rows(); ++i) design.push_back(D.row(i).transpose());
  fit.design_points = static_cast<int>(design.size());
  run(design);

  auto train = [&] {
    std::vector<GaussianProcess> em(static_cast<size_t>(m));
    Eigen::MatrixXd Xm(static_cast<long>(X.size()), d);
    for (size_t k = 0; k < X.size(); ++k) Xm.row(static_cast<long>(k)) = X[k].transpose();
    for (long i = 0; i < m; ++i) {
      Eigen::VectorXd y(static_cast<long>(Y.size()));
      for (size_t k = 0; k < Y.size(); ++k) y(static_cast<long>(k)) = Y[k](i);
      em[static_cast<size_t>(i)].fit(Xm, y);
    }
    return em;
  };
  auto starts_for = [&](const std::vector<GaussianProcess>&) {
    // the best runs so far and the centre of the box
    std::vector<size_t> idx(X.size());
    std::iota(idx.begin(), idx.end(), size_t{0});
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
      return chi2_of(Y[a], targets, sigmas) < chi2_of(Y[b], targets, sigmas);
    });
    std::vector<Eigen::VectorXd> s;
    for (size_t k = 0; k < std::min<size_t>(4, idx.size()); ++k) s.push_back(X[idx[k]]);
    s.push_back(Eigen::VectorXd::Constant(d, 0.5));
    return s;
  };

  if (X.size() < 2) {  // nothing to learn from: every design run failed
    fit.run_chi2 = std::numeric_limits<double>::infinity();
    fit.predicted.chi2 = fit.predicted.deviance = std::numeric_limits<double>::infinity();
    return fit;
  }
  std::vector<GaussianProcess> em = train();
  // two fidelities: a first pair at the cheap emulators' optimum when none is known
  auto run_full = [&](const Eigen::VectorXd& x) {
    const auto out = (*full)({x});
    ++fit.full_runs;
    return out.empty() ? Eigen::VectorXd() : out[0];
  };
  fit.screened = full && opt.screen;
  const bool run_full_too = full && !opt.screen;
  if (run_full_too && pairs.empty()) {
    const Eigen::VectorXd x0 = box_minimum(
        [&](const Eigen::VectorXd& x) { return emulated_deviance(em, targets, sigmas, x).deviance; }, starts_for(em), nullptr);
    const auto c0 = run({x0});
    const Eigen::VectorXd f0 = run_full(x0);
    if (ok_out(c0[0]) && ok_out(f0)) pairs.push_back({x0, c0[0], f0});
    em = train();
  }
  if (full) dz = learn_discrepancy(pairs, em);
  Eigen::VectorXd xstar;
  std::vector<Eigen::VectorXd> round_x, round_out;  // per round: the optimum and its run
  std::vector<double> round_z;
  for (int round = 0; round < opt.max_rounds; ++round) {
    // the optimum of the emulators' expected chi2
    auto deviance = [&](const Eigen::VectorXd& x) { return emulated_deviance(em, targets, sigmas, x, dzp).deviance; };
    xstar = box_minimum(deviance, starts_for(em), nullptr);
    const EmulatedDeviance at = emulated_deviance(em, targets, sigmas, xstar, dzp);
    std::vector<GaussianProcess::Prediction> pred;  // of the simulator the fit is for
    for (size_t i = 0; i < em.size(); ++i) {
      auto p = em[i].predict(xstar);
      if (run_full_too && dz.pairs > 0) {  // (screening checks the cheap emulators by a cheap run)
        p.mean += dz.mean(static_cast<long>(i), xstar);
        p.nugget += dz.var(static_cast<long>(i), xstar);
      }
      pred.push_back(p);
    }
    // the batch: the optimum, then where a believed optimum leaves the lowest confidence bound
    std::vector<Eigen::VectorXd> batch{xstar};
    std::vector<GaussianProcess> believed = em;
    for (int q = 1; q < opt.batch; ++q) {
      const Eigen::VectorXd& last = batch.back();
      for (size_t i = 0; i < believed.size(); ++i) believed[i] = believed[i].with_point(last, believed[i].predict(last).mean);
      auto lcb = [&](const Eigen::VectorXd& x) { return chi2_lcb(believed, targets, sigmas, x, dzp); };
      std::vector<Eigen::VectorXd> st = starts_for(believed);
      // and a spread of starts around the optimum, so the picks are not all the same point
      for (int j = 0; j < d; ++j)
        for (double sgn : {-1.0, 1.0}) {
          Eigen::VectorXd x = xstar;
          x(j) = std::min(1.0, std::max(0.0, x(j) + 0.15 * sgn));
          st.push_back(x);
        }
      batch.push_back(box_minimum(lcb, st, nullptr));
    }
    auto out = run(batch);
    if (run_full_too) {  // the optimum on the full simulator too: the confirmation, and a pair
      const Eigen::VectorXd f = run_full(xstar);
      if (ok_out(out[0]) && ok_out(f)) pairs.push_back({xstar, out[0], f});
      out[0] = f;
    }
    fit.rounds = round + 1;
    const bool ok = out[0].size() == m && out[0].allFinite();
    double worst = std::numeric_limits<double>::infinity();
    if (ok) {
      worst = 0;
      for (long i = 0; i < m; ++i) {
        const auto& p = pred[static_cast<size_t>(i)];
        worst = std::max(worst, std::fabs(out[0](i) - p.mean) / std::sqrt(p.variance + p.nugget));
      }
    }
    fit.round_predicted.push_back(at.chi2);
    fit.round_confirmed.push_back(ok ? chi2_of(out[0], targets, sigmas) : std::numeric_limits<double>::infinity());
    fit.x = xstar;
    fit.predicted = at;
    fit.worst_z = worst;
    // confirmed: the run is what the emulators said it would be, output by output; converged:
    // and their own uncertainty there is small beside the noise it is compared with
    fit.confirmed = ok && worst <= opt.confirm_z;
    fit.converged = fit.confirmed && at.latent_share <= opt.max_latent_share;
    fit.outputs = ok ? out[0] : Eigen::VectorXd();
    fit.run_chi2 = fit.round_confirmed.back();
    round_x.push_back(xstar);
    round_out.push_back(fit.outputs);
    round_z.push_back(worst);
    em = train();  // the new runs join the emulators
    if (full) dz = learn_discrepancy(pairs, em);
    if (fit.converged) break;
  }
  // Not converged within the rounds: of the optima the rounds ran, the one the final
  // emulators (which know every run) find best; each has a real run.
  if (!fit.converged && !round_x.empty()) {
    double best = std::numeric_limits<double>::infinity();
    for (size_t r = 0; r < round_x.size(); ++r) {
      const double dv = emulated_deviance(em, targets, sigmas, round_x[r], dzp).deviance;
      if (round_out[r].size() == m && dv < best) {
        best = dv;
        fit.x = round_x[r];
        fit.outputs = round_out[r];
        fit.run_chi2 = fit.round_confirmed[r];
        fit.worst_z = round_z[r];
        fit.confirmed = round_z[r] <= opt.confirm_z;
      }
    }
  }
  // the fit as the final emulators see it at x
  fit.predicted = emulated_deviance(em, targets, sigmas, fit.x, dzp);
  if (!opt.nested_face.empty()) {
    // the free coordinates searched, the face's fixed
    std::vector<int> free;
    for (int j = 0; j < d; ++j)
      if (std::none_of(opt.nested_face.begin(), opt.nested_face.end(), [&](const auto& f) { return f.first == j; }))
        free.push_back(j);
    auto on_face = [&](const Eigen::VectorXd& z) {
      Eigen::VectorXd x(d);
      for (const auto& [j, v] : opt.nested_face) x(j) = v;
      for (size_t k = 0; k < free.size(); ++k) x(free[k]) = z(static_cast<long>(k));
      return x;
    };
    if (free.empty()) {
      fit.nested_x = on_face(Eigen::VectorXd());
    } else {
      std::vector<Eigen::VectorXd> starts;
      Eigen::VectorXd z(static_cast<long>(free.size()));
      for (size_t k = 0; k < free.size(); ++k) z(static_cast<long>(k)) = fit.x(free[k]);
      starts.push_back(z);
      starts.push_back(Eigen::VectorXd::Constant(static_cast<long>(free.size()), 0.5));
      for (size_t i = 0; i < X.size(); ++i) {  // the runs on the face
        bool on = true;
        for (const auto& [j, v] : opt.nested_face) on = on && std::fabs(X[i](j) - v) < 1e-9;
        if (!on) continue;
        for (size_t k = 0; k < free.size(); ++k) z(static_cast<long>(k)) = X[i](free[k]);
        starts.push_back(z);
        if (starts.size() > 6) break;
      }
      const Eigen::VectorXd zb = box_minimum(
          [&](const Eigen::VectorXd& zz) { return emulated_deviance(em, targets, sigmas, on_face(zz), dzp).deviance; }, starts,
          nullptr);
      fit.nested_x = on_face(zb);
    }
    fit.nested = emulated_deviance(em, targets, sigmas, fit.nested_x, dzp);
  }
  fit.mean.resize(m);
  fit.sd.resize(m);
  for (long i = 0; i < m; ++i) {
    const auto p = em[static_cast<size_t>(i)].predict(fit.x);
    const bool shift = dzp && dz.pairs > 0;
    fit.mean(i) = p.mean + (shift ? dz.mean(i, fit.x) : 0.0);
    fit.sd(i) = std::sqrt(p.variance + p.nugget + (shift ? dz.var(i, fit.x) : 0.0));
  }
  fit.discrepancy = dz;
  // the linearised uncertainty of x from the emulators' gradients (central differences),
  // each output weighted by its observation and predictive variance
  {
    const double h = 1e-3;
    Eigen::MatrixXd J(m, d);
    Eigen::VectorXd w(m);
    for (long i = 0; i < m; ++i) {
      const auto p = em[static_cast<size_t>(i)].predict(fit.x);
      w(i) = 1.0 / (sigmas(i) * sigmas(i) + p.variance + p.nugget + (dzp && dz.pairs > 0 ? dz.var(i, fit.x) : 0.0));
      for (int j = 0; j < d; ++j) {
        Eigen::VectorXd a = fit.x, b = fit.x;
        a(j) = std::min(1.0, a(j) + h);
        b(j) = std::max(0.0, b(j) - h);
        J(i, j) = (em[static_cast<size_t>(i)].predict(a).mean - em[static_cast<size_t>(i)].predict(b).mean) / (a(j) - b(j));
      }
    }
    const Eigen::MatrixXd F = J.transpose() * w.asDiagonal() * J;
    fit.cov = (F + 1e-12 * Eigen::MatrixXd::Identity(d, d)).inverse();
  }
  // leave-one-out per output, in the observation's sigma
  fit.loo_rmse_sigma.resize(m);
  fit.loo_z_rms.resize(m);
  for (long i = 0; i < m; ++i) {
    const auto& g = em[static_cast<size_t>(i)];
    const auto loo = g.leave_one_out();
    const Eigen::VectorXd e = loo.mean - g.outputs();
    fit.loo_rmse_sigma(i) = std::sqrt(e.squaredNorm() / e.size()) / sigmas(i);
    fit.loo_z_rms(i) = std::sqrt(e.cwiseQuotient(loo.sd).squaredNorm() / e.size());
  }
  fit.emulators = std::move(em);
  return fit;
}

}  // namespace tamp::loop
