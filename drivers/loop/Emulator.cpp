#include "drivers/loop/Emulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

namespace tamp::loop {

Eigen::MatrixXd maximin_lhs(int n, int d, std::uint64_t seed, int tries) {
  if (n < 1 || d < 1) throw std::invalid_argument("maximin_lhs: n and d must be >= 1");
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd best;
  double best_d = -1;
  std::vector<int> perm(static_cast<size_t>(n));
  for (int t = 0; t < std::max(1, tries); ++t) {
    Eigen::MatrixXd X(n, d);
    for (int j = 0; j < d; ++j) {
      std::iota(perm.begin(), perm.end(), 0);
      std::shuffle(perm.begin(), perm.end(), rng);
      for (int i = 0; i < n; ++i) X(i, j) = (perm[static_cast<size_t>(i)] + u(rng)) / n;
    }
    double dmin = std::numeric_limits<double>::infinity();
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) dmin = std::min(dmin, (X.row(a) - X.row(b)).squaredNorm());
    if (dmin > best_d) {
      best_d = dmin;
      best = X;
    }
  }
  return best;
}

Eigen::VectorXd nelder_mead(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x0,
                            double step, int max_evals, double* fmin) {
  const long m = x0.size();
  std::vector<Eigen::VectorXd> s{x0};
  std::vector<double> v{f(x0)};
  for (long j = 0; j < m; ++j) {
    Eigen::VectorXd x = x0;
    x(j) += step;
    s.push_back(x);
    v.push_back(f(x));
  }
  int evals = static_cast<int>(m + 1);
  std::vector<size_t> idx(s.size());
  auto order = [&] {
    std::iota(idx.begin(), idx.end(), size_t{0});
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
    std::vector<Eigen::VectorXd> s2;
    std::vector<double> v2;
    for (size_t i : idx) {
      s2.push_back(s[i]);
      v2.push_back(v[i]);
    }
    s = s2;
    v = v2;
  };
  while (evals < max_evals) {
    order();
    if (std::fabs(v[m] - v[0]) <= 1e-10 * (1 + std::fabs(v[0]))) break;
    Eigen::VectorXd c = Eigen::VectorXd::Zero(m);
    for (long k = 0; k < m; ++k) c += s[k] / static_cast<double>(m);
    const Eigen::VectorXd xr = c + (c - s[m]);
    const double fr = f(xr);
    ++evals;
    if (fr < v[0]) {
      const Eigen::VectorXd xe = c + 2.0 * (c - s[m]);
      const double fe = f(xe);
      ++evals;
      if (fe < fr) { s[m] = xe; v[m] = fe; } else { s[m] = xr; v[m] = fr; }
    } else if (fr < v[m - 1]) {
      s[m] = xr;
      v[m] = fr;
    } else {
      const bool outside = fr < v[m];
      const Eigen::VectorXd xc = outside ? Eigen::VectorXd(c + 0.5 * (xr - c)) : Eigen::VectorXd(c + 0.5 * (s[m] - c));
      const double fc = f(xc);
      ++evals;
      if (fc < (outside ? fr : v[m])) {
        s[m] = xc;
        v[m] = fc;
      } else {
        for (long k = 1; k <= m; ++k) {
          s[k] = s[0] + 0.5 * (s[k] - s[0]);
          v[k] = f(s[k]);
          ++evals;
        }
      }
    }
  }
  order();
  if (fmin) *fmin = v[0];
  return s[0];
}

// ------------------------------------------------------------------ the process

namespace {
constexpr double kLogEllMin = -3.5066, kLogEllMax = 3.4012;  // l in [0.03, 30]
constexpr double kLogGMin = -18.42, kLogGMax = 0.0;           // g in [1e-8, 1]
double clampd(double x, double lo, double hi) { return std::min(hi, std::max(lo, x)); }
}  // namespace

double GaussianProcess::correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  const double r = std::sqrt((a - b).cwiseQuotient(ell_).squaredNorm());
  const double s5r = std::sqrt(5.0) * r;
  return (1.0 + s5r + 5.0 * r * r / 3.0) * std::exp(-s5r);
}

Eigen::VectorXd GaussianProcess::trend(const Eigen::VectorXd& x) const {
  if (!linear_trend_) return Eigen::VectorXd::Ones(1);
  Eigen::VectorXd h(x.size() + 1);
  h(0) = 1.0;
  h.tail(x.size()) = x;
  return h;
}

void GaussianProcess::factorise() {
  const long n = X_.rows();
  Eigen::MatrixXd R(n, n);
  for (long i = 0; i < n; ++i) {
    R(i, i) = 1.0 + g_;
    for (long j = 0; j < i; ++j) R(i, j) = R(j, i) = correlation(X_.row(i).transpose(), X_.row(j).transpose());
  }
  llt_.compute(R);
  const long p = linear_trend_ ? X_.cols() + 1 : 1;
  H_.resize(n, p);
  for (long i = 0; i < n; ++i) H_.row(i) = trend(X_.row(i).transpose()).transpose();
  RiH_ = llt_.solve(H_);
  HtRiH_.compute(H_.transpose() * RiH_);
  beta_ = HtRiH_.solve(RiH_.transpose() * ys_);
  alpha_ = llt_.solve(ys_ - H_ * beta_);
  s2_ = std::max(1e-300, (ys_ - H_ * beta_).dot(alpha_) / std::max<long>(1, n - p));
}

double GaussianProcess::neg_log_likelihood(const Eigen::VectorXd& theta) const {
  GaussianProcess g = *this;
  const long d = X_.cols();
  for (long j = 0; j < d; ++j) g.ell_(j) = std::exp(clampd(theta(j), kLogEllMin, kLogEllMax));
  g.g_ = std::exp(clampd(theta(d), kLogGMin, kLogGMax));
  g.factorise();
  if (g.llt_.info() != Eigen::Success) return 1e30;
  const long n = X_.rows(), p = g.H_.cols();
  double logdet = 0;
  const Eigen::MatrixXd L = g.llt_.matrixL();
  for (long i = 0; i < n; ++i) logdet += 2.0 * std::log(L(i, i));
  const Eigen::VectorXd dH = g.HtRiH_.vectorD();
  double logdetH = 0;
  for (long i = 0; i < dH.size(); ++i) logdetH += std::log(std::max(1e-300, std::fabs(dH(i))));
  // the restricted likelihood with s2 profiled out (Santner et al. 2003, sec. 3.3)
  double nll = 0.5 * ((n - p) * std::log(g.s2_) + logdet + logdetH);
  // keep the search inside the box (a smooth wall: the clamp alone makes the objective flat)
  for (long j = 0; j < d; ++j) nll += 10.0 * (std::pow(std::max(0.0, theta(j) - kLogEllMax), 2) +
                                              std::pow(std::max(0.0, kLogEllMin - theta(j)), 2));
  nll += 10.0 * (std::pow(std::max(0.0, theta(d) - kLogGMax), 2) + std::pow(std::max(0.0, kLogGMin - theta(d)), 2));
  return std::isfinite(nll) ? nll : 1e30;
}

void GaussianProcess::fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  if (X.rows() != y.size() || X.rows() < 2) throw std::invalid_argument("GaussianProcess::fit: at least 2 points, X rows = y size");
  X_ = X;
  y_ = y;
  const long n = X.rows(), d = X.cols();
  centre_ = y.mean();
  scale_ = std::sqrt((y.array() - centre_).square().sum() / std::max<long>(1, n - 1));
  if (!(scale_ > 0)) scale_ = std::max(1e-12, std::fabs(centre_) * 1e-12 + 1e-300);
  ys_ = (y.array() - centre_) / scale_;
  linear_trend_ = n >= 2 * (d + 1);
  ell_ = Eigen::VectorXd::Constant(d, 0.5);
  // multi-start: short, middle, long length scales; a small and a moderate nugget
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_theta;
  for (double l0 : {0.2, 0.7, 2.5})
    for (double g0 : {1e-4, 1e-2}) {
      Eigen::VectorXd t0(d + 1);
      t0.head(d).setConstant(std::log(l0));
      t0(d) = std::log(g0);
      double f = 0;
      const Eigen::VectorXd t = nelder_mead([&](const Eigen::VectorXd& th) { return neg_log_likelihood(th); }, t0, 0.7,
                                            60 + 40 * static_cast<int>(d), &f);
      if (f < best) {
        best = f;
        best_theta = t;
      }
    }
  for (long j = 0; j < d; ++j) ell_(j) = std::exp(clampd(best_theta(j), kLogEllMin, kLogEllMax));
  g_ = std::exp(clampd(best_theta(d), kLogGMin, kLogGMax));
  factorise();
}

GaussianProcess::Prediction GaussianProcess::predict(const Eigen::VectorXd& x) const {
  const long n = X_.rows();
  Eigen::VectorXd r(n);
  for (long i = 0; i < n; ++i) r(i) = correlation(x, X_.row(i).transpose());
  const Eigen::VectorXd h = trend(x);
  Prediction p;
  p.mean = centre_ + scale_ * (h.dot(beta_) + r.dot(alpha_));
  const Eigen::VectorXd Rir = llt_.solve(r);
  const Eigen::VectorXd u = h - RiH_.transpose() * r;  // H^T R^-1 r
  const double v = 1.0 - r.dot(Rir) + u.dot(HtRiH_.solve(u));
  p.variance = std::max(0.0, v) * s2_ * scale_ * scale_;
  p.nugget = g_ * s2_ * scale_ * scale_;
  return p;
}

GaussianProcess GaussianProcess::with_point(const Eigen::VectorXd& x, double y) const {
  GaussianProcess g = *this;
  g.X_.conservativeResize(X_.rows() + 1, Eigen::NoChange);
  g.X_.row(X_.rows()) = x.transpose();
  g.y_.conservativeResize(y_.size() + 1);
  g.y_(y_.size()) = y;
  g.ys_ = (g.y_.array() - centre_) / scale_;
  const double s2 = s2_;
  g.factorise();
  g.s2_ = s2;  // the believer's point carries no information on the variance
  return g;
}

GaussianProcess::LeaveOneOut GaussianProcess::leave_one_out() const {
  const long n = X_.rows(), d = X_.cols();
  LeaveOneOut out{Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (long i = 0; i < n; ++i) {
    GaussianProcess g = *this;
    g.X_.resize(n - 1, d);
    g.y_.resize(n - 1);
    for (long k = 0, m = 0; k < n; ++k) {
      if (k == i) continue;
      g.X_.row(m) = X_.row(k);
      g.y_(m) = y_(k);
      ++m;
    }
    g.ys_ = (g.y_.array() - centre_) / scale_;
    g.linear_trend_ = linear_trend_ && n - 1 >= d + 2;
    g.factorise();
    g.s2_ = s2_;
    const Prediction p = g.predict(X_.row(i).transpose());
    out.mean(i) = p.mean;
    out.sd(i) = std::sqrt(p.variance + p.nugget);
  }
  return out;
}

}  // namespace tamp::loop
