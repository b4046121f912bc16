#include "drivers/loop/Calibration.hpp"
#include "core/MaterialModel.hpp"

#include <Eigen/Dense>
#include <unsupported/Eigen/SpecialFunctions>  // igammac: the chi-square goodness of fit
#ifdef TAMP_HAVE_NLOPT
#include <nlopt.h>
#endif
#include <nlohmann/json.hpp>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <thread>

#include "core/Deck.hpp"
#include "core/Format.hpp"
#include "core/Log.hpp"
#include "drivers/sequence/DropSequence.hpp"
#include "drivers/loop/ForwardRuns.hpp"
#include "drivers/loop/Ranks.hpp"
#include "kernels/solver/Simulation.hpp"
#include "drivers/loop/EmulatedFit.hpp"

namespace tamp {
namespace fs = std::filesystem;

// ------------------------------------------------------------------ forward runs

RunOutputs run_forward(const Config& cfg, const std::string& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const log::Level level = log::level();
  log::set_level(log::Level::Quiet);
  RunOutputs o;
  try {
    Simulation sim(cfg);
    DropSequence seq(sim, cfg, dir);
    seq.set_stage_files(false);
    seq.run();
    o.summary = summary_values(seq.summary(0.0));
    for (const auto& b : seq.blows()) {  // every column of blows.csv's table, as a run folder has them
      std::map<std::string, double> row;
      for (const auto& col : blow_columns()) row[col.name] = b.*col.field;
      o.blows.push_back(row);
    }
  } catch (...) {
    log::set_level(level);
    throw;
  }
  log::set_level(level);
  return o;
}

// A finished run folder: summary.json (a JSON object of numbers; null for a quantity the run
// could not measure) and blows.csv (a header, then numbers). A damaged file is an error
// naming the file and, for the table, the row and column, never a silent zero.
RunOutputs read_run_dir(const std::string& dir) {
  RunOutputs o;
  const std::string summary = dir + "/summary.json";
  {
    std::error_code ec;
    if (!std::filesystem::exists(summary, ec))
      throw std::invalid_argument(printable(summary) + " does not exist (is '" + printable(dir) + "' a finished tamp run?)");
  }
  o.summary = read_run_summary(summary);
  const std::string table = dir + "/blows.csv";
  {
    std::error_code ec;
    if (!std::filesystem::exists(table, ec)) throw std::invalid_argument(printable(table) + " does not exist");
  }
  require_regular_file(table, "blow table (CSV)");
  std::ifstream bl(table);
  std::string line;
  // RFC 4180 ends lines with CRLF: a line's CR is not part of its last cell
  auto getline_csv = [&](std::string& l) {
    if (!std::getline(bl, l)) return false;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    return true;
  };
  getline_csv(line);
  std::vector<std::string> header;
  {
    std::stringstream hs(line);
    for (std::string h; std::getline(hs, h, ',');) header.push_back(h);
  }
  if (header.empty()) throw std::invalid_argument(table + " has no header row");
  for (int row_no = 2; getline_csv(line); ++row_no) {
    std::stringstream ls(line);
    std::map<std::string, double> row;
    size_t k = 0;
    for (std::string cell; std::getline(ls, cell, ',') && k < header.size(); ++k) {
      double x = 0;
      const auto res = std::from_chars(cell.data(), cell.data() + cell.size(), x);
      if (res.ec != std::errc() || res.ptr != cell.data() + cell.size() || !std::isfinite(x))
        throw std::invalid_argument(printable(table) + " row " + std::to_string(row_no) + ", column " + printable(header[k], 60) +
                                    ": '" + printable(cell, 60) + "' is not a finite number");
      row[header[k]] = x;
    }
    if (k != header.size())
      throw std::invalid_argument(table + " row " + std::to_string(row_no) + " has " + std::to_string(k) + " cells; the header has " +
                                  std::to_string(header.size()));
    o.blows.push_back(row);
  }
  return o;
}

// ------------------------------------------------------------------ parameters

namespace {

double* param_ref(Config& cfg, const std::string& name) {
  const auto dot = name.find('.');
  const std::string contact_keys = "contact.<key> with key static_friction, dynamic_friction, decay";
  auto material_keys = [](const MaterialSpec& m) {
    std::string s;
    for (const ModelKey* k : keys_of(material_model(m)))
      if (k->fittable) s += (s.empty() ? "" : ", ") + k->key;
    return s;
  };
  std::string allowed = contact_keys;
  for (const auto& m : cfg.materials) allowed += "; " + m.name + ".<key> with key " + material_keys(m);
  if (dot == std::string::npos) throw std::invalid_argument("parameter '" + name + "' is not known; allowed: " + allowed);
  const std::string owner = name.substr(0, dot), key = name.substr(dot + 1);
  if (owner == "contact") {
    if (key == "static_friction") return &cfg.contact.static_friction;
    if (key == "dynamic_friction") return &cfg.contact.dynamic_friction;
    if (key == "decay") return &cfg.contact.decay;
    throw std::invalid_argument("parameter '" + name + "' is not known; allowed: " + contact_keys);
  }
  // The fittable keys of the material's model (core/MaterialModel.hpp).
  for (auto& m : cfg.materials) {
    if (m.name != owner) continue;
    for (const ModelKey* k : keys_of(material_model(m)))
      if (k->fittable && k->key == key) return &key_value(m, *k);
    throw std::invalid_argument("parameter '" + name + "' is not known; allowed: " + owner + ".<key> with key " +
                                material_keys(m));
  }
  throw std::invalid_argument("parameter '" + name + "': the deck has no material '" + owner + "'");
}

bool is_fraction(const std::string& name) { return name.size() >= 15 && name.substr(name.size() - 15) == "remoulded_ratio"; }

// Fitted coordinate t of a parameter value: log for positive parameters, logit for the
// remoulded ratio (0, 1).
double to_t(const std::string& name, double v) {
  if (is_fraction(name)) {
    v = std::min(std::max(v, 1e-6), 1 - 1e-6);
    return std::log(v / (1 - v));
  }
  return std::log(std::max(v, 1e-300));
}
double from_t(const std::string& name, double t) {
  if (is_fraction(name)) return 1.0 / (1.0 + std::exp(-t));
  return std::exp(t);
}
double dvalue_dt(const std::string& name, double v) { return is_fraction(name) ? v * (1 - v) : v; }

double model_value(const Observation& o, const RunOutputs& run) {
  if (o.blow > 0) {
    if (o.blow > static_cast<int>(run.blows.size())) return std::numeric_limits<double>::quiet_NaN();
    const auto& row = run.blows[o.blow - 1];
    const auto it = row.find(o.quantity);
    return it == row.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
  }
  const auto it = run.summary.find(o.quantity);
  return it == run.summary.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
}

std::string fmt_g(double v, const char* f = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string quantity_label(const Observation& o) {
  return o.blow > 0 ? o.quantity + " (blow " + std::to_string(o.blow) + ")" : o.quantity;
}

}  // namespace

double get_param(const Config& cfg, const std::string& name) {
  Config copy = cfg;
  return *param_ref(copy, name);
}

void set_param(Config& cfg, const std::string& name, double value) { *param_ref(cfg, name) = value; }

bool has_param(const Config& cfg, const std::string& name) {
  try {
    (void)get_param(cfg, name);
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

// ------------------------------------------------------------------ residuals

std::vector<Residual> residuals(const ObservationSet& data, const RunOutputs& run) {
  std::vector<Residual> out;
  for (const auto& o : data.observations) {
    Residual r;
    r.obs = &o;
    r.model = model_value(o, run);
    // A quantity the run did not produce counts as a large misfit (100 sigma).
    r.normalised = std::isfinite(r.model) ? (r.model - o.value) / o.sigma : 100.0;
    out.push_back(r);
  }
  return out;
}

double rms(const std::vector<Residual>& r) {
  if (r.empty()) return 0.0;
  double s = 0;
  for (const auto& x : r) s += x.normalised * x.normalised;
  return std::sqrt(s / r.size());
}

std::string residual_table(const std::vector<Residual>& r) {
  std::ostringstream o;
  o << "| quantity | measured | uncertainty | model | normalised residual |\n|---|---|---|---|---|\n";
  for (const auto& x : r) {
    const Observation& ob = *x.obs;
    o << "| " << quantity_label(ob) << " | "
      << (ob.is_range ? "[" + fmt_g(ob.lo) + ", " + fmt_g(ob.hi) + "]" : fmt_g(ob.value)) << " | " << fmt_g(ob.sigma)
      << (ob.is_range ? " (half range)" : "") << " | " << fmt_g(x.model) << " | " << fmt_g(x.normalised, "%+.2f")
      << " |\n";
  }
  o << "\nOverall error (RMS of the normalised residuals): " << fmt_g(rms(r), "%.3f") << "\n";
  return o.str();
}

UnexplainedResidual unexplained_residual(const std::vector<Residual>& r, double threshold, int fitted_params,
                                         double p_min) {
  UnexplainedResidual u;
  u.threshold = threshold;
  u.p_min = p_min;
  u.error = rms(r);
  for (const Residual& x : r) u.chi2 += x.normalised * x.normalised;
  u.dof = static_cast<int>(r.size()) - fitted_params;
  // chi-square goodness of fit: the probability of a chi2 this large from the noise alone,
  // Q(dof/2, chi2/2) (Eigen's regularised upper incomplete gamma)
  if (u.dof >= 1 && std::isfinite(u.chi2)) {
    Eigen::ArrayXd a(1), x(1);
    a << 0.5 * u.dof;
    x << 0.5 * u.chi2;
    u.p_value = Eigen::igammac(a, x)(0);
  }
  u.too_large_error = u.error > threshold;
  u.poor_fit = u.dof >= 1 && u.p_value < p_min;
  u.remains = u.too_large_error || u.poor_fit;
  if (!u.remains) return u;
  for (const Residual& x : r) {
    if (!(std::fabs(x.normalised) > threshold)) continue;
    auto g = std::find_if(u.groups.begin(), u.groups.end(), [&](const UnexplainedGroup& e) { return e.quantity == x.obs->quantity; });
    if (g == u.groups.end()) g = u.groups.insert(u.groups.end(), UnexplainedGroup{x.obs->quantity, {}, 0, 0, 0.0});
    g->blows.push_back(x.obs->blow);
    (x.normalised > 0 ? g->above : g->below) += 1;
    if (std::fabs(x.normalised) > std::fabs(g->largest)) g->largest = x.normalised;
  }
  return u;
}

std::string UnexplainedResidual::text() const {
  const std::string fit = dof >= 1 ? "chi2 " + fmt_g(chi2, "%.1f") + " on " + std::to_string(dof) +
                                         " degrees of freedom, p = " + fmt_g(p_value, "%.2g")
                                   : std::string("no degrees of freedom left");
  if (!remains)
    return "the error " + fmt_g(error, "%.3f") + " is within " + fmt_g(threshold, "%g") + " and the fit is within the " +
           "noise (" + fit + "): no residual is left that the catalogue does not explain";
  std::string s = "a residual remains that the catalogue does not explain (";
  if (too_large_error) s += "error " + fmt_g(error, "%.3f") + " > " + fmt_g(threshold, "%g") + "; ";
  s += fit + (poor_fit ? " < " + fmt_g(p_min, "%g") + ": more misfit than the uncertainties explain" : std::string()) + ")";
  if (groups.empty()) s += ": no single observation beyond " + fmt_g(threshold, "%g") + " uncertainties";
  for (size_t k = 0; k < groups.size(); ++k) {
    const UnexplainedGroup& g = groups[k];
    s += (k ? "; " : ": ") + g.quantity;
    if (g.blows.size() > 1 || g.blows.front() > 0) {
      s += " (blow";
      for (size_t b = 0; b < g.blows.size(); ++b) s += (b ? ", " : " ") + std::to_string(g.blows[b]);
      s += ")";
    }
    const int n = g.above + g.below;
    s += g.below == 0 ? ", model above the measurement" : g.above == 0 ? ", model below the measurement"
         : ", model above in " + std::to_string(g.above) + " and below in " + std::to_string(g.below) + " of " + std::to_string(n);
    s += ", largest residual " + fmt_g(g.largest, "%+.2f");
  }
  return s;
}

std::string residuals_json(const std::vector<Residual>& r) {
  nlohmann::ordered_json j;
  j["error"] = rms(r);
  j["observations"] = nlohmann::ordered_json::array();
  for (const Residual& x : r) {
    const Observation& ob = *x.obs;
    nlohmann::ordered_json e;
    e["quantity"] = ob.quantity;
    e["blow"] = ob.blow;
    e["value"] = ob.value;
    e["sigma"] = ob.sigma;
    e["model"] = x.model;  // NaN (not produced) is written as null
    e["normalised_residual"] = x.normalised;
    j["observations"].push_back(e);
  }
  return j.dump(2) + "\n";
}

// ------------------------------------------------------------------ calibration

namespace {
// The forward runs of `opt` (its runner, or one made here for this fit).
struct Runner {
  std::unique_ptr<ForwardRuns> own;
  ForwardRuns* runs;
  explicit Runner(const CalibrateOptions& opt) {
    if (opt.runner) {
      runs = opt.runner;
    } else {
      ForwardRunOptions fo;
      fo.scratch = opt.scratch;
      own = std::make_unique<ForwardRuns>(fo);
      runs = own.get();
    }
  }
};

// chi2 of a forward run: infinite for a failed run (a failed point, not a crash).
double chi2_of(const ObservationSet& data, const ForwardResult& r, Eigen::VectorXd* normalised = nullptr) {
  const int n = static_cast<int>(data.observations.size());
  if (normalised) *normalised = Eigen::VectorXd::Zero(n);
  if (!r.ok) return std::numeric_limits<double>::infinity();
  const auto res = residuals(data, r.outputs);
  double chi2 = 0;
  for (int i = 0; i < n; ++i) {
    chi2 += res[i].normalised * res[i].normalised;
    if (normalised) (*normalised)(i) = res[i].normalised;
  }
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}
}  // namespace

double FitResult::bic() const { return chi2 + static_cast<double>(names.size()) * std::log(static_cast<double>(n)); }

namespace {
FitResult calibrate_nm(const Config& cfg0, const ObservationSet& data, const std::vector<std::string>& params,
                       const CalibrateOptions& opt);
FitResult calibrate_nlopt(const Config& cfg0, const ObservationSet& data, const std::vector<std::string>& params,
                          const CalibrateOptions& opt);

// The starting point of a fit in the fitted coordinates (log, or logit for a fraction).
Eigen::VectorXd start_point(const Config& cfg0, const std::vector<std::string>& params) {
  if (params.empty()) throw std::invalid_argument("calibrate: no parameters to fit");
  Eigen::VectorXd t(params.size());
  for (size_t j = 0; j < params.size(); ++j) {
    const double v = get_param(cfg0, params[j]);
    if (!(v > 0)) throw std::invalid_argument("calibrate: parameter " + params[j] + " starts at " + fmt_g(v) +
                                              "; it must start > 0 (it is fitted in log space)");
    t(static_cast<long>(j)) = to_t(params[j], v);
  }
  return t;
}

// The fit at its best point t: values, linearised 1-sigma uncertainties cov(t) = (J^T J)^-1
// (normalised residuals), chi2, the outputs and residuals of the best run.
void finish_fit(FitResult& fit, const ObservationSet& data, const Eigen::VectorXd& t, const Eigen::MatrixXd& J,
                double chi2, const RunOutputs& best) {
  const long p = t.size();
  const Eigen::MatrixXd cov = (J.transpose() * J + 1e-12 * Eigen::MatrixXd::Identity(p, p)).inverse();
  for (long j = 0; j < p; ++j) {
    const double v = from_t(fit.names[j], t(j));
    fit.values.push_back(v);
    fit.sigmas.push_back(std::sqrt(std::max(0.0, cov(j, j))) * dvalue_dt(fit.names[j], v));
  }
  fit.chi2 = chi2;
  fit.outputs = best;
  fit.residuals = residuals(data, best);
  fit.error = rms(fit.residuals);
}
}

FitResult calibrate(const Config& cfg0, const ObservationSet& data, const std::vector<std::string>& params,
                    const CalibrateOptions& opt) {
  if (opt.method == "nelder-mead") return calibrate_nm(cfg0, data, params, opt);
  if (opt.method == "sbplx" || opt.method == "bobyqa") return calibrate_nlopt(cfg0, data, params, opt);
  if (opt.method != "lm")
    throw std::invalid_argument("calibrate: method '" + opt.method + "'; allowed: nelder-mead, lm, sbplx, bobyqa");
  const int p = static_cast<int>(params.size());
  const int n = static_cast<int>(data.observations.size());
  Eigen::VectorXd t = start_point(cfg0, params);
  FitResult fit;
  fit.names = params;
  fit.n = n;
  Runner runner(opt);
  auto config_at = [&](const Eigen::VectorXd& tt) {
    Config c = cfg0;
    for (int j = 0; j < p; ++j) set_param(c, params[j], from_t(params[j], tt(j)));
    return c;
  };
  auto eval = [&](const Eigen::VectorXd& tt, RunOutputs* out) {
    const ForwardResult fr = runner.runs->run(config_at(tt));
    ++fit.runs;
    Eigen::VectorXd r(n);
    if (!std::isfinite(chi2_of(data, fr, &r))) r.setConstant(1e150);  // a failed point: never accepted
    if (out) *out = fr.outputs;
    return r;
  };
  // the finite-difference columns at t, run side by side
  auto jacobian = [&](const Eigen::VectorXd& tt, const Eigen::VectorXd& r0, double step) {
    std::vector<Config> batch;
    for (int j = 0; j < p; ++j) {
      Eigen::VectorXd tj = tt;
      tj(j) += step;
      batch.push_back(config_at(tj));
    }
    const auto results = runner.runs->run(batch);
    fit.runs += p;
    Eigen::MatrixXd Jm(n, p);
    for (int j = 0; j < p; ++j) {
      Eigen::VectorXd rj;
      Jm.col(j) = std::isfinite(chi2_of(data, results[j], &rj)) ? Eigen::VectorXd((rj - r0) / step)
                                                                 : Eigen::VectorXd::Zero(n);  // failed: no information
    }
    return Jm;
  };
  auto describe = [&](const Eigen::VectorXd& tt) {
    std::string s;
    for (int j = 0; j < p; ++j) s += (j ? ", " : "") + params[j] + " = " + fmt_g(from_t(params[j], tt(j)));
    return s;
  };
  RunOutputs best_out;
  Eigen::VectorXd r = eval(t, &best_out);
  double chi2 = r.squaredNorm();
  if (opt.verbose) log::info("calibrate: start " + describe(t) + ": chi2 " + fmt_g(chi2));
  double lambda = 1e-2;
  Eigen::MatrixXd J(n, p);
  for (int it = 0; it < opt.max_iterations; ++it) {
    J = jacobian(t, r, opt.step);
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool accepted = false;
    const double chi_old = chi2;
    for (int tries = 0; tries < 4 && !accepted; ++tries) {
      Eigen::MatrixXd M = A;
      for (int j = 0; j < p; ++j) M(j, j) += lambda * A(j, j) + 1e-12;
      Eigen::VectorXd d = M.ldlt().solve(-g);
      for (int j = 0; j < p; ++j) d(j) = std::max(-1.0, std::min(1.0, d(j)));  // at most a factor e per step
      RunOutputs o;
      const Eigen::VectorXd tn = t + d;
      const Eigen::VectorXd rn = eval(tn, &o);
      const double chin = rn.squaredNorm();
      if (chin < chi2) {
        t = tn; r = rn; chi2 = chin; best_out = o;
        lambda = std::max(1e-6, lambda / 3);
        accepted = true;
      } else {
        lambda *= 4;
      }
    }
    if (opt.verbose)
      log::info("calibrate: iteration " + std::to_string(it + 1) + ": " + describe(t) + ": chi2 " + fmt_g(chi2) +
                (accepted ? "" : " (no better step)"));
    if (!accepted || (chi_old - chi2) < 1e-3 * chi_old) break;
  }
  finish_fit(fit, data, t, J, chi2, best_out);
  return fit;
}

namespace {
// Nelder-Mead on chi2 in the fitted coordinates (Lagarias et al. 1998 coefficients 1, 2,
// 0.5, 0.5), then a finite-difference Jacobian at the best point for the uncertainty.
FitResult calibrate_nm(const Config& cfg0, const ObservationSet& data, const std::vector<std::string>& params,
                       const CalibrateOptions& opt) {
  const int p = static_cast<int>(params.size());
  const int n = static_cast<int>(data.observations.size());
  if (p == 0) throw std::invalid_argument("calibrate: no parameters to fit");
  const int budget = opt.max_runs > 0 ? opt.max_runs : 12 + 20 * p;
  FitResult fit;
  fit.names = params;
  fit.n = n;
  struct Point {
    Eigen::VectorXd t;
    double chi2;
    RunOutputs out;
    Eigen::VectorXd r;
  };
  Runner runner(opt);
  // the points of `ts`, run side by side (a failed run is a point of infinite chi2)
  auto eval_batch = [&](const std::vector<Eigen::VectorXd>& ts) {
    std::vector<Config> batch;
    for (const auto& tt : ts) {
      Config c = cfg0;
      for (int j = 0; j < p; ++j) set_param(c, params[j], from_t(params[j], tt(j)));
      batch.push_back(c);
    }
    const auto results = runner.runs->run(batch);
    fit.runs += static_cast<int>(ts.size());
    std::vector<Point> q;
    for (size_t k = 0; k < ts.size(); ++k) {
      Point pt{ts[k], 0.0, results[k].outputs, Eigen::VectorXd(n)};
      pt.chi2 = chi2_of(data, results[k], &pt.r);
      q.push_back(pt);
    }
    return q;
  };
  auto eval = [&](const Eigen::VectorXd& tt) { return eval_batch({tt})[0]; };
  auto describe = [&](const Eigen::VectorXd& tt) {
    std::string s;
    for (int j = 0; j < p; ++j) s += (j ? ", " : "") + params[j] + " = " + fmt_g(from_t(params[j], tt(j)));
    return s;
  };
  const Eigen::VectorXd t0 = start_point(cfg0, params);
  std::vector<Eigen::VectorXd> first{t0};  // the first simplex, run side by side
  for (int j = 0; j < p; ++j) {
    Eigen::VectorXd t = t0;
    t(j) += j < static_cast<int>(opt.simplex_steps.size()) ? opt.simplex_steps[j] : 0.3;
    first.push_back(t);
  }
  std::vector<Point> s = eval_batch(first);
  auto order = [&] { std::sort(s.begin(), s.end(), [](const Point& a, const Point& b) { return a.chi2 < b.chi2; }); };
  order();
  if (opt.verbose) log::info("calibrate (Nelder-Mead): start " + describe(s[0].t) + ": chi2 " + fmt_g(s[0].chi2));
  while (fit.runs < budget) {
    order();
    if (s[p].chi2 - s[0].chi2 <= 1e-3 * std::max(1.0, s[0].chi2)) break;  // flat simplex
    Eigen::VectorXd c = Eigen::VectorXd::Zero(p);
    for (int k = 0; k < p; ++k) c += s[k].t / p;
    const Point xr = eval(c + (c - s[p].t));
    if (xr.chi2 < s[0].chi2) {
      const Point xe = eval(c + 2.0 * (c - s[p].t));
      s[p] = xe.chi2 < xr.chi2 ? xe : xr;
    } else if (xr.chi2 < s[p - 1].chi2) {
      s[p] = xr;
    } else {
      const bool outside = xr.chi2 < s[p].chi2;
      const Point xc = eval(outside ? Eigen::VectorXd(c + 0.5 * (xr.t - c)) : Eigen::VectorXd(c + 0.5 * (s[p].t - c)));
      if (xc.chi2 < (outside ? xr.chi2 : s[p].chi2)) {
        s[p] = xc;
      } else {  // shrink toward the best
        std::vector<Eigen::VectorXd> shrunk;
        for (int k = 1; k <= p && fit.runs + static_cast<int>(shrunk.size()) < budget; ++k)
          shrunk.push_back(s[0].t + 0.5 * (s[k].t - s[0].t));
        const std::vector<Point> q = eval_batch(shrunk);
        for (size_t k = 0; k < q.size(); ++k) s[k + 1] = q[k];
      }
    }
    order();
    if (opt.verbose) log::info("calibrate: run " + std::to_string(fit.runs) + ": best " + describe(s[0].t) + ": chi2 " + fmt_g(s[0].chi2));
  }
  order();
  const Point& best = s[0];
  // linearised uncertainty from forward differences at the best point
  Eigen::MatrixXd J(n, p);
  const double h = 0.05;
  std::vector<Eigen::VectorXd> columns;
  for (int j = 0; j < p; ++j) {
    Eigen::VectorXd t = best.t;
    t(j) += h;
    columns.push_back(t);
  }
  const std::vector<Point> q = eval_batch(columns);
  for (int j = 0; j < p; ++j)  // a failed column carries no information
    J.col(j) = std::isfinite(q[j].chi2) ? Eigen::VectorXd((q[j].r - best.r) / h) : Eigen::VectorXd::Zero(n);
  finish_fit(fit, data, best.t, J, best.chi2, best.out);
  return fit;
}

#ifdef TAMP_HAVE_NLOPT
// NLopt's bounded derivative-free local methods on chi2 in the fitted coordinates: Sbplx
// (Rowan's subplex, Nelder-Mead on subspaces) or BOBYQA (Powell's quadratic models), within
// +-3 of the start (a factor of 20 either way in log space), at most the run budget less the
// p runs of the Jacobian at the best point, which gives the uncertainty as for Nelder-Mead.
// A failed run is a point of chi2 1e30 (NLopt wants a finite value).
FitResult calibrate_nlopt(const Config& cfg0, const ObservationSet& data, const std::vector<std::string>& params,
                          const CalibrateOptions& opt) {
  const int p = static_cast<int>(params.size());
  const int n = static_cast<int>(data.observations.size());
  const Eigen::VectorXd t0 = start_point(cfg0, params);
  const int budget = opt.max_runs > 0 ? opt.max_runs : 12 + 20 * p;
  FitResult fit;
  fit.names = params;
  fit.n = n;
  Runner runner(opt);
  struct Context {
    const Config* cfg0;
    const ObservationSet* data;
    const std::vector<std::string>* params;
    ForwardRuns* runs;
    FitResult* fit;
    Eigen::VectorXd best_t, best_r;
    double best_chi2 = std::numeric_limits<double>::infinity();
    RunOutputs best_out;
    std::string failure;  // an exception from a forward run, rethrown after NLopt returns
  } ctx{&cfg0, &data, &params, runner.runs, &fit, t0, Eigen::VectorXd::Zero(n), std::numeric_limits<double>::infinity(),
         RunOutputs{}, std::string{}};
  auto objective = [](unsigned dim, const double* x, double* /*grad*/, void* data_ptr) -> double {
    Context& c = *static_cast<Context*>(data_ptr);
    try {
      Config cfg = *c.cfg0;
      Eigen::VectorXd t(dim);
      for (unsigned j = 0; j < dim; ++j) {
        t(j) = x[j];
        set_param(cfg, (*c.params)[j], from_t((*c.params)[j], x[j]));
      }
      const ForwardResult r = c.runs->run(cfg);
      ++c.fit->runs;
      Eigen::VectorXd res;
      const double chi2 = chi2_of(*c.data, r, &res);
      if (chi2 < c.best_chi2) {
        c.best_chi2 = chi2;
        c.best_t = t;
        c.best_r = res;
        c.best_out = r.outputs;
      }
      return std::isfinite(chi2) ? chi2 : 1e30;
    } catch (const std::exception& e) {
      c.failure = e.what();
      return 1e30;
    }
  };
  nlopt_opt o = nlopt_create(opt.method == "bobyqa" ? NLOPT_LN_BOBYQA : NLOPT_LN_SBPLX, static_cast<unsigned>(p));
  std::vector<double> x(t0.data(), t0.data() + p), lb(p), ub(p), dx(p);
  for (int j = 0; j < p; ++j) {
    lb[j] = t0(j) - 3.0;
    ub[j] = t0(j) + 3.0;
    dx[j] = j < static_cast<int>(opt.simplex_steps.size()) ? opt.simplex_steps[j] : 0.3;
  }
  nlopt_set_lower_bounds(o, lb.data());
  nlopt_set_upper_bounds(o, ub.data());
  nlopt_set_initial_step(o, dx.data());
  nlopt_set_min_objective(o, objective, &ctx);
  nlopt_set_maxeval(o, std::max(2 * p + 1, budget - p));
  nlopt_set_ftol_abs(o, 1e-3);  // the flat-simplex test of the Nelder-Mead fit
  double fmin = 0;
  const nlopt_result rc = nlopt_optimize(o, x.data(), &fmin);
  nlopt_destroy(o);
  if (!ctx.failure.empty()) throw std::runtime_error("calibrate (" + opt.method + "): " + ctx.failure);
  if (opt.verbose)
    log::info("calibrate (" + opt.method + "): " + std::to_string(fit.runs) + " runs, chi2 " + fmt_g(ctx.best_chi2) +
              " (NLopt code " + std::to_string(static_cast<int>(rc)) + ")");
  // the Jacobian at the best point (its columns side by side)
  std::vector<Config> batch;
  const double h = 0.05;
  for (int j = 0; j < p; ++j) {
    Config c = cfg0;
    for (int k = 0; k < p; ++k) set_param(c, params[k], from_t(params[k], ctx.best_t(k) + (k == j ? h : 0.0)));
    batch.push_back(c);
  }
  const auto cols = runner.runs->run(batch);
  fit.runs += p;
  Eigen::MatrixXd J(n, p);
  for (int j = 0; j < p; ++j) {
    Eigen::VectorXd rj;
    J.col(j) = std::isfinite(chi2_of(data, cols[j], &rj)) ? Eigen::VectorXd((rj - ctx.best_r) / h)
                                                          : Eigen::VectorXd::Zero(n);
  }
  finish_fit(fit, data, ctx.best_t, J, ctx.best_chi2, ctx.best_out);
  return fit;
}
#else
FitResult calibrate_nlopt(const Config&, const ObservationSet&, const std::vector<std::string>&,
                          const CalibrateOptions& opt) {
  throw std::invalid_argument("calibrate: method '" + opt.method +
                              "' needs NLopt, which this build lacks (apt-get install libnlopt-cxx-dev, then rebuild)");
}
#endif
}  // namespace

// ------------------------------------------------------------------ calibration on emulators

void RunArchive::add(const Config& cfg, const RunOutputs& out) {
  std::lock_guard<std::mutex> lock(m_);
  runs_.emplace_back(cfg, out);
}

std::vector<std::pair<Config, RunOutputs>> RunArchive::runs() const {
  std::lock_guard<std::mutex> lock(m_);
  return runs_;
}

void RunArchive::count(bool cheap, long runs, double wall_s) {
  std::lock_guard<std::mutex> lock(m_);
  (cheap ? cheap_runs_ : full_runs_) += runs;
  (cheap ? cheap_wall_ : full_wall_) += wall_s;
}
long RunArchive::cheap_runs() const {
  std::lock_guard<std::mutex> lock(m_);
  return cheap_runs_;
}
long RunArchive::full_runs() const {
  std::lock_guard<std::mutex> lock(m_);
  return full_runs_;
}
double RunArchive::cost_ratio() const {
  std::lock_guard<std::mutex> lock(m_);
  if (cheap_runs_ == 0 || full_runs_ == 0 || !(full_wall_ > 0)) return std::numeric_limits<double>::quiet_NaN();
  return (cheap_wall_ / static_cast<double>(cheap_runs_)) / (full_wall_ / static_cast<double>(full_runs_));
}
double RunArchive::default_deck_equivalents() const {
  const double r = cost_ratio();
  std::lock_guard<std::mutex> lock(m_);
  if (cheap_runs_ == 0) return static_cast<double>(full_runs_);
  return static_cast<double>(full_runs_) + static_cast<double>(cheap_runs_) * (std::isfinite(r) ? r : 1.0);
}

Config canonical_effects(Config cfg) {
  for (auto& m : cfg.materials) {
    // no air voids to lose: no compaction (the deck reader refuses a crush pressure without air
    // voids, so this is also what makes the deck at an emulator's "off" face a valid deck)
    if (m.crush_pressure <= 0 || m.air_voids <= 0) {
      m.crush_pressure = 0;
      m.air_voids = 0;
      m.crush_hardening = 0;
    }
    if (m.rate_coefficient <= 0) {
      m.rate_coefficient = 0;
      m.reference_strain_rate = 1.0;
    }
    if (m.remoulded_ratio >= 1) {
      m.remoulded_ratio = 1.0;
      m.remoulding_strain = 1.0;
    }
  }
  return cfg;
}


FitResult calibrate_emulated(const Config& cfg0, const ObservationSet& data, const std::vector<ParameterRange>& ranges,
                             const EmulatorSettings& settings, ForwardRuns& runs, const std::string& seed_label,
                             RunArchive* archive, const std::vector<std::string>& nested_off) {
  const int d = static_cast<int>(ranges.size());
  const long n = static_cast<long>(data.observations.size());
  if (d == 0) throw std::invalid_argument("calibrate: no parameters to fit");
  std::vector<double> tlo(d), thi(d);
  for (int j = 0; j < d; ++j) {
    const ParameterRange& r = ranges[static_cast<size_t>(j)];
    if (!((r.linear ? r.lo >= 0 : r.lo > 0) && r.hi > r.lo && std::isfinite(r.hi)))
      throw std::invalid_argument("calibrate: the range of " + r.name + " is [" + fmt_g(r.lo) + ", " + fmt_g(r.hi) +
                                  "]; allowed: 0 < lo < hi (0 <= lo for a linear range), finite");
    (void)get_param(cfg0, r.name);  // a known parameter of the deck
    tlo[static_cast<size_t>(j)] = r.linear ? r.lo : to_t(r.name, r.lo);
    thi[static_cast<size_t>(j)] = r.linear ? r.hi : to_t(r.name, r.hi);
  }
  auto value_at = [&](const Eigen::VectorXd& x, int j) {
    const size_t k = static_cast<size_t>(j);
    const double t = tlo[k] + x(j) * (thi[k] - tlo[k]);
    return ranges[k].linear ? t : from_t(ranges[k].name, t);
  };
  auto unit_of = [&](double v, int j) {
    const size_t k = static_cast<size_t>(j);
    return ((ranges[k].linear ? v : to_t(ranges[k].name, v)) - tlo[k]) / (thi[k] - tlo[k]);
  };
  auto config_at = [&](const Eigen::VectorXd& x) {  // a valid deck: an effect at "off" written off
    Config c = cfg0;
    for (int j = 0; j < d; ++j) set_param(c, ranges[static_cast<size_t>(j)].name, value_at(x, j));
    return canonical_effects(c);
  };
  Eigen::VectorXd targets(n), sigmas(n);
  for (long i = 0; i < n; ++i) {
    targets(i) = data.observations[static_cast<size_t>(i)].value;
    sigmas(i) = data.observations[static_cast<size_t>(i)].sigma;
  }
  std::vector<std::pair<Eigen::VectorXd, RunOutputs>> done;  // every successful full run, for the fit's outputs
  const bool two = !settings.cheap_overrides.empty();
  auto cheap_of = [&](const Config& c) {  // (an effect at "off" written off first, as config_at does)
    return parse_deck(to_toml(canonical_effects(c)), "the cheap deck", settings.cheap_overrides);
  };
  auto simulate_on = [&](const std::vector<Eigen::VectorXd>& pts, bool cheap) {
    std::vector<Config> batch;
    for (const auto& x : pts) batch.push_back(cheap ? cheap_of(config_at(x)) : config_at(x));
    const auto t0 = std::chrono::steady_clock::now();
    const auto results = runs.run(batch);
    if (archive)
      archive->count(cheap, static_cast<long>(batch.size()),
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::vector<Eigen::VectorXd> out;
    for (size_t k = 0; k < pts.size(); ++k) {
      if (!results[k].ok) {
        out.emplace_back();
        continue;
      }
      const auto res = residuals(data, results[k].outputs);
      Eigen::VectorXd y(n);
      bool finite = true;
      for (long i = 0; i < n; ++i) {
        y(i) = res[static_cast<size_t>(i)].model;
        finite = finite && std::isfinite(y(i));
      }
      out.push_back(finite ? y : Eigen::VectorXd());
      if (finite && !cheap) done.emplace_back(pts[k], results[k].outputs);
      if (archive) archive->add(batch[k], results[k].outputs);
    }
    return out;
  };
  const loop::UnitSimulator simulate = [&](const std::vector<Eigen::VectorXd>& pts) { return simulate_on(pts, two); };
  const loop::UnitSimulator simulate_full = [&](const std::vector<Eigen::VectorXd>& pts) { return simulate_on(pts, false); };
  loop::EmulatedFitOptions o;
  o.points_per_parameter = settings.points_per_parameter;
  o.batch = settings.batch;
  o.max_rounds = settings.max_rounds;
  o.confirm_z = settings.confirm_z;
  o.max_latent_share = settings.max_latent_share;
  o.screen = two && settings.screen;
  o.seed = std::stoull(deck_key(seed_label), nullptr, 16);
  // Earlier runs in the box: each archived deck read as a point (a parameter outside the box
  // taken at its "off" value, or mid-range where the effect it belongs to is off), kept when
  // the deck at that point runs the same physics as the archived one.
  std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> prior, full_seen;
  std::vector<loop::DiscrepancyPair> prior_pairs;
  if (archive) {
    for (const auto& [rc, ro] : archive->runs()) {
      Config at = cfg0;
      Eigen::VectorXd x(d);
      bool inside = true;
      for (int j = 0; j < d && inside; ++j) {
        const ParameterRange& r = ranges[static_cast<size_t>(j)];
        double v = 0;
        try {
          v = get_param(rc, r.name);
        } catch (const std::invalid_argument&) {
          inside = false;
          break;
        }
        if (!(v >= r.lo && v <= r.hi)) v = r.off >= r.lo && r.off <= r.hi ? r.off : value_at(Eigen::VectorXd::Constant(d, 0.5), j);
        set_param(at, r.name, v);
        x(j) = unit_of(v, j);
      }
      if (!inside) continue;
      const std::string deck = to_toml(canonical_effects(rc));
      const bool is_full = deck == to_toml(canonical_effects(at));
      const bool is_cheap = two && deck == to_toml(canonical_effects(cheap_of(at)));
      if (!is_full && !is_cheap) continue;
      const auto res = residuals(data, ro);
      Eigen::VectorXd y(n);
      bool finite = true;
      for (long i = 0; i < n; ++i) {
        y(i) = res[static_cast<size_t>(i)].model;
        finite = finite && std::isfinite(y(i));
      }
      if (!finite) continue;
      if (is_full && two) {
        full_seen.emplace_back(x, y);
        done.emplace_back(x, ro);
        continue;
      }
      prior.emplace_back(x, y);
      if (is_full) done.emplace_back(x, ro);
    }
    // In the order of the points, not of the archive: the archive holds the runs in the order
    // the side-by-side fits happened to add them, and the emulators' fits must not depend on
    // that (the answer is the same for any number of workers).
    auto by_point = [](const auto& a, const auto& b) {
      for (long j = 0; j < a.first.size(); ++j)
        if (a.first(j) != b.first(j)) return a.first(j) < b.first(j);
      for (long i = 0; i < a.second.size(); ++i)
        if (a.second(i) != b.second(i)) return a.second(i) < b.second(i);
      return false;
    };
    std::sort(prior.begin(), prior.end(), by_point);
    std::sort(full_seen.begin(), full_seen.end(), by_point);
    // pairs: a full run at a point where a cheap one ran
    for (const auto& [xf, yf] : full_seen)
      for (const auto& [xc, yc] : prior)
        if ((xf - xc).norm() < 1e-12) {
          prior_pairs.push_back({xf, yc, yf});
          break;
        }
  }
  // the nested model's face: the effect's "off" keys at off, their companions mid-range
  for (int j = 0; j < d; ++j) {
    const ParameterRange& r = ranges[static_cast<size_t>(j)];
    if (std::find(nested_off.begin(), nested_off.end(), r.name) == nested_off.end()) continue;
    o.nested_face.emplace_back(j, r.off >= r.lo && r.off <= r.hi ? unit_of(r.off, j) : 0.5);
  }
  const loop::EmulatedFit ef = loop::emulated_fit(simulate, targets, sigmas, d, o, prior, two ? &simulate_full : nullptr,
                                                  prior_pairs);
  FitResult fit;
  fit.n = static_cast<int>(n);
  fit.runs = ef.runs + ef.full_runs;
  fit.confirmed = ef.converged;
  fit.screened = ef.screened;
  for (const auto& r : ranges) fit.names.push_back(r.name);
  if (ef.x.size() != d) {  // every run failed
    fit.chi2 = std::numeric_limits<double>::infinity();
    fit.error = std::numeric_limits<double>::infinity();
    fit.values.assign(static_cast<size_t>(d), std::numeric_limits<double>::quiet_NaN());
    fit.sigmas = fit.values;
    return fit;
  }
  for (int j = 0; j < d; ++j) {
    const double v = value_at(ef.x, j);
    const double dt = thi[static_cast<size_t>(j)] - tlo[static_cast<size_t>(j)];
    fit.values.push_back(v);
    const ParameterRange& r = ranges[static_cast<size_t>(j)];
    fit.sigmas.push_back(std::sqrt(std::max(0.0, ef.cov(j, j))) * dt * (r.linear ? 1.0 : dvalue_dt(r.name, v)));
  }
  // The fit as the emulators see it (docs/closing-the-loop.md "Emulators"): per observation
  // their mean at the optimum, normalised by sigma^2 plus their predictive variance; chi2 is the
  // deviance (with the likelihood's normalisation, sum ln(1 + v / sigma^2)), so that BIC =
  // deviance + k ln n is the Gaussian likelihood's. The confirmation run's own residuals go
  // to the JSON beside them.
  for (const auto& [x, out] : done)
    if (x == ef.x) fit.outputs = out;
  fit.chi2 = ef.predicted.deviance;
  if (!o.nested_face.empty()) fit.nested_deviance = ef.nested.deviance;
  fit.residuals = residuals(data, fit.outputs);
  const double run_error = rms(fit.residuals);
  for (long i = 0; i < n; ++i) {
    Residual& r = fit.residuals[static_cast<size_t>(i)];
    r.model = ef.mean(i);
    r.normalised = (ef.mean(i) - targets(i)) / std::sqrt(sigmas(i) * sigmas(i) + ef.sd(i) * ef.sd(i));
  }
  fit.error = rms(fit.residuals);

  nlohmann::ordered_json j;
  j["design_points"] = ef.design_points;
  j["rounds"] = ef.rounds;
  j["runs"] = ef.runs;
  j["failed_runs"] = ef.failed;
  j["batch"] = settings.batch;
  if (two) {
    j["cheap_deck"] = settings.cheap_overrides;
    j["screened"] = ef.screened;  // confirmed by cheap runs only
    j["full_runs"] = ef.full_runs;
    j["cheap_runs"] = ef.runs;
    j["pairs"] = ef.discrepancy.pairs;
    j["discrepancy"] = nlohmann::ordered_json::array();
    j["discrepancy_linear"] = ef.discrepancy.linear;
    for (long i = 0; i < n && ef.discrepancy.pairs > 0; ++i)  // at the fit
      j["discrepancy"].push_back({{"quantity", quantity_label(data.observations[static_cast<size_t>(i)])},
                                  {"full_minus_cheap", ef.discrepancy.mean(i, ef.x)},
                                  {"sd", std::sqrt(ef.discrepancy.var(i, ef.x))}});
  }
  j["chi2"] = ef.predicted.chi2;
  j["deviance"] = ef.predicted.deviance;
  j["latent_share"] = ef.predicted.latent_share;
  if (!o.nested_face.empty()) j["nested_deviance"] = ef.nested.deviance;
  j["confirmed"] = ef.confirmed;
  j["converged"] = ef.converged;
  j["confirmation_worst_z"] = ef.worst_z;
  j["confirm_z"] = settings.confirm_z;
  j["confirmation_run_chi2"] = ef.run_chi2;
  j["confirmation_run_error"] = run_error;
  j["rounds_emulated_chi2"] = ef.round_predicted;
  j["rounds_run_chi2"] = ef.round_confirmed;
  j["prediction"] = nlohmann::ordered_json::array();
  for (long i = 0; i < n; ++i)
    j["prediction"].push_back({{"quantity", quantity_label(data.observations[static_cast<size_t>(i)])},
                               {"measured", targets(i)}, {"sigma", sigmas(i)}, {"emulator_mean", ef.mean(i)},
                               {"emulator_sd", ef.sd(i)}, {"confirmation_run", ef.outputs.size() == n ? ef.outputs(i) : NAN}});
  j["leave_one_out"] = nlohmann::ordered_json::array();
  for (long i = 0; i < n; ++i)
    j["leave_one_out"].push_back({{"quantity", quantity_label(data.observations[static_cast<size_t>(i)])},
                                  {"rmse_in_sigma", ef.loo_rmse_sigma(i)},
                                  {"standardised_rms", ef.loo_z_rms(i)}});
  j["parameters"] = nlohmann::ordered_json::array();
  for (int k = 0; k < d; ++k) {
    const ParameterRange& r = ranges[static_cast<size_t>(k)];
    // identified: the data pin the parameter to within a quarter of its range (1 sd, fitted
    // coordinate); a parameter that is not is fixed where the catalogue fixes it
    const double sd_unit = std::sqrt(std::max(0.0, ef.cov(k, k)));
    j["parameters"].push_back({{"name", r.name}, {"lo", r.lo}, {"hi", r.hi}, {"source", r.source},
                               {"value", fit.values[static_cast<size_t>(k)]}, {"sigma", fit.sigmas[static_cast<size_t>(k)]},
                               {"sd_in_range", sd_unit}, {"identified", sd_unit < 0.25}});
  }
  fit.emulator_json = j.dump();
  return fit;
}

// ------------------------------------------------------------------ effects

std::vector<ParameterRange> default_ranges(const Config& cfg, const std::vector<std::string>& names) {
  std::vector<ParameterRange> out;
  for (const auto& p : names) {
    const std::string key = p.substr(p.find('.') + 1);
    const EffectCandidate::KeyRange* cr = catalogue_range(key);
    const double v = get_param(cfg, p);  // a known parameter (throws, naming what is allowed)
    if (cr && p.rfind("contact.", 0) != 0)
      out.push_back({p, cr->lo, cr->hi, cr->source, cr->linear, cr->off});
    else if (v > 0)
      out.push_back({p, 0.5 * v, 2.0 * v, "the deck's value within a factor 2"});
    else
      throw std::invalid_argument("calibrate: parameter " + p + " is " + fmt_g(v) +
                                  " in the deck and has no catalogue range; allowed: a parameter > 0 (its range is a "
                                  "factor 2 either side) or an effect's key");
  }
  return out;
}

void apply_effect(Config& cfg, const std::string& material, const std::string& effect,
                  const std::map<std::string, double>& overrides) {
  if (effect != "none") {
    const EffectCandidate* e = nullptr;
    for (const auto& c : effect_catalogue())
      if (c.name == effect) e = &c;
    for (const auto& c : model_switch_catalogue())
      if (c.name == effect) e = &c;
    if (!e)
      throw std::invalid_argument("effect '" + effect +
                                  "' is not known; allowed: none, compaction, rate, remoulding, modified-cam-clay");
    if (!e->model.empty()) {  // a model switch: the strength from the material's Su, then the new model's keys
      MaterialSpec* m = nullptr;
      for (auto& mm : cfg.materials)
        if (mm.name == material) m = &mm;
      if (!m) throw std::invalid_argument("effect '" + effect + "': the deck has no material '" + material + "'");
      if (m->cohesion <= 0)
        throw std::invalid_argument("effect '" + effect + "' on '" + material + "': its Su (c) is " +
                                    std::to_string(m->cohesion) + "; allowed: Su > 0, from which " + e->strength +
                                    " starts");
      const double su = m->cohesion;
      m->model = e->model;
      // every key of the new model the switch names (fitted or not, e.g. v0), by the model's table
      auto set_key = [&](const std::string& key, double v) {
        for (const ModelKey* k : keys_of(material_model(*m)))
          if (k->key == key) { key_value(*m, *k) = v; return; }
        throw std::invalid_argument("effect '" + effect + "': model '" + e->model + "' has no key '" + key + "'");
      };
      set_key(e->strength, e->strength_per_su * su);
      for (const auto& [k, v] : e->fixed) set_key(k, v);
      for (const auto& [k, v] : e->fitted) set_key(k, v);
    } else {
      for (const auto& [k, v] : e->fixed) set_param(cfg, material + "." + k, v);
      for (const auto& [k, v] : e->fitted) set_param(cfg, material + "." + k, v);
    }
  }
  for (const auto& [k, v] : overrides) set_param(cfg, k.find('.') == std::string::npos ? material + "." + k : k, v);
}

// ------------------------------------------------------------------ diagnosis

namespace {
nlohmann::ordered_json fit_json(const std::string& name, const FitResult& f) {
  nlohmann::ordered_json j;
  j["effect"] = name;
  j["chi2"] = f.chi2;
  j["error"] = f.error;
  j["bic"] = f.bic();
  j["runs"] = f.runs;
  j["parameters"] = nlohmann::ordered_json::object();
  for (size_t k = 0; k < f.names.size(); ++k) j["parameters"][f.names[k]] = {{"value", f.values[k]}, {"sigma", f.sigmas[k]}};
  const auto hv = f.outputs.summary.find("heave_volume_m3"), av = f.outputs.summary.find("aggregate_volume_below_ground_m3");
  double ratio = std::numeric_limits<double>::quiet_NaN();
  if (hv != f.outputs.summary.end() && av != f.outputs.summary.end() && av->second > 0) ratio = hv->second / av->second;
  j["heave_to_column_volume"] = ratio;  // null when not measured
  if (!f.emulator_json.empty()) j["emulator"] = nlohmann::ordered_json::parse(f.emulator_json);
  return j;
}
}  // namespace

namespace {
// The traces of a forward run that point to a cause (issue: the loop on the lab): the volume
// balance, and per blow the crater depth, the deepest point, the landings and the first
// rebound's restitution, and where the blow's energy went (% of the energy brought).
std::string trace_report(const RunOutputs& run) {
  std::ostringstream md;
  auto get = [](const std::map<std::string, double>& m, const std::string& k) {
    const auto it = m.find(k);
    return it == m.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
  };
  const double hv = get(run.summary, "heave_volume_m3"), av = get(run.summary, "aggregate_volume_below_ground_m3");
  md << "Volume balance: heave " << fmt_g(hv * 1e6, "%.0f") << " cm3 against " << fmt_g(av * 1e6, "%.0f")
     << " cm3 of aggregate below the ground (ratio " << (av > 0 ? fmt_g(hv / av, "%.2f") : std::string("n/a"))
     << "; about 1 for an undrained soil, less for one that compacts).\n\n";
  if (run.blows.empty()) return md.str();
  std::vector<std::string> plastic;  // plastic_<material>_J columns
  for (const auto& [k, v] : run.blows[0])
    if (k.rfind("plastic_", 0) == 0) plastic.push_back(k);
  md << "| blow | crater depth (mm) | deepest (mm) | landings | restitution | energy in (J) |";
  for (const auto& k : plastic) md << " " << k.substr(8, k.size() - 10) << " plastic |";
  md << " radiated | returned | residual |\n|---|---|---|---|---|---|";
  for (size_t k = 0; k < plastic.size(); ++k) md << "---|";
  md << "---|---|---|\n";
  for (size_t b = 0; b < run.blows.size(); ++b) {
    const auto& r = run.blows[b];
    const double e = get(r, "energy_in_J");
    auto share = [&](const std::string& k) { return e > 0 ? fmt_g(100 * get(r, k) / e, "%.0f") + " %" : std::string("-"); };
    md << "| " << b + 1 << " | " << fmt_g(1e3 * get(r, "crater_depth_m"), "%.1f") << " | "
       << fmt_g(1e3 * get(r, "deepest_m"), "%.1f") << " | " << fmt_g(get(r, "contacts"), "%.0f") << " | "
       << fmt_g(get(r, "restitution"), "%.2f") << " | " << fmt_g(e, "%.1f") << " |";
    for (const auto& k : plastic) md << " " << share(k) << " |";
    md << " " << share("radiated_J") << " | " << share("returned_J") << " | " << share("residual_J") << " |\n";
  }
  return md.str() + "\n";
}

// Coordinate scan of each parameter over `factors` of its current value (one at a time),
// then Nelder-Mead from the best point with first steps `step`: a particle model's response
// has small jumps in which a local search alone gets stuck.
FitResult scan_then_polish(Config start, const ObservationSet& data, const std::vector<std::string>& params,
                           const std::vector<double>& factors, double step, int polish_runs, const CalibrateOptions& o) {
  Runner runner(o);
  int runs = 0;
  for (const auto& name : params) {
    const double v0 = get_param(start, name);
    double v_best = v0, best = std::numeric_limits<double>::infinity();
    std::vector<Config> batch;  // the scan's points, run side by side
    for (double f : factors) {
      Config c = start;
      set_param(c, name, v0 * f);
      batch.push_back(c);
    }
    const auto results = runner.runs->run(batch);
    runs += static_cast<int>(batch.size());
    for (size_t k = 0; k < factors.size(); ++k) {
      const double chi2 = chi2_of(data, results[k]);
      if (chi2 < best) { best = chi2; v_best = v0 * factors[k]; }
    }
    set_param(start, name, v_best);
  }
  CalibrateOptions polish = o;
  polish.max_runs = polish_runs;
  polish.simplex_steps.assign(params.size(), step);
  FitResult f = calibrate(start, data, params, polish);
  f.runs += runs;
  return f;
}
}  // namespace

namespace {
using StepCandidate = DiagnosisCandidate;

// The grid of the scan of the first baseline parameter at each profile value of an effect
// (factors of its current value, 10-15 % apart, 0.5-1.5): wide enough for the strength that an
// effect trades against (the rate test: Su 0.65 of the baseline fit with the effect in place).
const std::vector<double>& profile_factors() {
  static const std::vector<double> f{0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.15, 1.3, 1.5};
  return f;
}

// The parameters a candidate is fitted with on top of the current model (`with_effect`: the
// current model with the candidate applied): the current ones, then the effect's own. A model
// switch replaces the parameters of its material that the new model does not have (Su of a
// Tresca clay) by its strength key: the same number of parameters as an effect. The profile
// method fits an effect's first key only (the others at their catalogue values, as it did
// before the emulators); the emulator fits them all (`all_keys`).
std::vector<std::string> candidate_params(const Config& with_effect, const std::vector<std::string>& current_params,
                                          const StepCandidate& cand, bool all_keys) {
  std::vector<std::string> params = current_params;
  if (!cand.effect->model.empty()) {
    const std::string strength = cand.material + "." + cand.effect->strength;
    params.clear();
    for (const auto& p : current_params) {
      const std::string q = has_param(with_effect, p) ? p : strength;
      if (std::find(params.begin(), params.end(), q) == params.end()) params.push_back(q);
    }
  }
  for (const auto& [k, v] : cand.effect->fitted) {
    params.push_back(cand.material + "." + k);
    if (!all_keys) break;
  }
  return params;
}

// A candidate refitted on top of the current model: a profile over the effect's grid (from
// nearly off to strong), at every grid value the first baseline parameter scanned over
// profile_factors() of its current value; all points of grid x scan are one batch, run side
// by side. Then Nelder-Mead over the current parameters and the effect's from the best point.
// (The strength and the effect trade off along a narrow valley that a simplex started at
// one end does not follow; the grid finds the valley, the simplex its floor.)
FitResult profile_fit(const Config& current, const std::vector<std::string>& current_params,
                      const std::string& refit_param0, const StepCandidate& cand, const ObservationSet& data,
                      const CalibrateOptions& opt) {
  Runner runner(opt);
  Config c = current;
  apply_effect(c, cand.material, cand.effect->name);
  const std::string key = cand.material + "." + cand.effect->fitted[0].first;
  std::string refit_param = refit_param0;
  if (!cand.effect->model.empty() && !has_param(c, refit_param)) refit_param = cand.material + "." + cand.effect->strength;
  const double v0 = get_param(c, refit_param);
  std::vector<Config> batch;
  for (double g : cand.effect->grid)
    for (double f : profile_factors()) {
      Config cg = c;
      set_param(cg, key, g);
      set_param(cg, refit_param, v0 * f);
      batch.push_back(cg);
    }
  const auto results = runner.runs->run(batch);
  double best = std::numeric_limits<double>::infinity();
  size_t best_k = 0;
  const size_t nf = profile_factors().size();
  for (size_t i = 0; i < cand.effect->grid.size(); ++i) {
    double row = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < nf; ++j) {
      const double chi2 = chi2_of(data, results[i * nf + j]);
      row = std::min(row, chi2);
      if (chi2 < best) { best = chi2; best_k = i * nf + j; }
    }
    log::info("diagnose:   " + key + " = " + fmt_g(cand.effect->grid[i]) + ": chi2 " + fmt_g(row) + " (best " +
              refit_param + " of the scan)");
  }
  const std::vector<std::string> params = candidate_params(c, current_params, cand, false);
  CalibrateOptions fo = opt;
  fo.max_runs = 6 + 5 * static_cast<int>(params.size());
  fo.simplex_steps.assign(params.size(), 0.1);
  FitResult f = calibrate(batch[best_k], data, params, fo);
  f.runs += static_cast<int>(batch.size());
  return f;
}

// The box of a candidate's emulator design (docs/closing-the-loop.md "Emulators"), the same
// for a parameter in every step, so that the runs of one step lie in the boxes of the next:
// the baseline's parameters over the baseline's box; an effect's keys over their catalogue
// ranges (its strength linear, with "off" at an end); a model switch's strength within a
// factor 2 of its start (from Su); any other parameter within a factor 2 of its value.
std::vector<ParameterRange> candidate_ranges(const Config& with_effect, const std::vector<std::string>& params,
                                             const StepCandidate& cand, const std::vector<ParameterRange>& baseline_box) {
  auto catalogue_range = [](const std::string& key) -> const EffectCandidate::KeyRange* {
    for (const auto* cat : {&effect_catalogue(), &model_switch_catalogue()})
      for (const auto& e : *cat)
        for (const auto& r : e.ranges)
          if (r.key == key && e.model.empty()) return &r;
    return nullptr;
  };
  std::vector<ParameterRange> out;
  for (const auto& p : params) {
    const std::string key = p.substr(p.find('.') + 1);
    const double v = get_param(with_effect, p);
    const bool strength = !cand.effect->model.empty() && p == cand.material + "." + cand.effect->strength;
    const EffectCandidate::KeyRange* cr = catalogue_range(key);
    const auto b = std::find_if(baseline_box.begin(), baseline_box.end(), [&](const ParameterRange& r) { return r.name == p; });
    if (b != baseline_box.end()) {
      out.push_back(*b);
    } else if (strength) {
      const auto k = std::find_if(cand.effect->ranges.begin(), cand.effect->ranges.end(),
                                   [&](const EffectCandidate::KeyRange& r) { return r.key == cand.effect->strength; });
      out.push_back({p, 0.5 * v, 2.0 * v,
                     k != cand.effect->ranges.end() ? k->source : std::string("its start within a factor 2")});
    } else if (cr) {
      out.push_back({p, cr->lo, cr->hi, cr->source, cr->linear, cr->off});
    } else if (!cand.effect->model.empty() && [&] {
                 for (const auto& r : cand.effect->ranges)
                   if (r.key == key) return true;
                 return false;
               }()) {
      for (const auto& r : cand.effect->ranges)
        if (r.key == key) out.push_back({p, r.lo, r.hi, r.source, r.linear, r.off});
    } else {
      out.push_back({p, 0.5 * v, 2.0 * v, "its value within a factor 2"});
    }
  }
  return out;
}

// A candidate fitted on emulators on top of the current model: its design over the
// current parameters and the effect's (candidate_ranges), seeded by the step and the label;
// the runs of the archive inside its box join its design.
FitResult emulated_candidate_fit(const Config& current, const std::vector<std::string>& current_params,
                                 const StepCandidate& cand, const ObservationSet& data, const DiagnoseOptions& opt,
                                 int step, const std::vector<ParameterRange>& baseline_box, RunArchive& archive) {
  Config c = current;
  apply_effect(c, cand.material, cand.effect->name);
  const std::vector<std::string> params = candidate_params(c, current_params, cand, true);
  // the current model is the candidate's box with the effect off: its keys at "off" (the
  // key that has one; the others are then without effect)
  std::vector<std::string> off;
  bool has_off = false;
  for (const auto& r : cand.effect->ranges) has_off = has_off || r.off >= r.lo;
  if (has_off && cand.effect->model.empty())
    for (const auto& [k, v] : cand.effect->fitted) off.push_back(cand.material + "." + k);
  return calibrate_emulated(c, data, candidate_ranges(c, params, cand, baseline_box), opt.emulator, *opt.fit.runner,
                            "step " + std::to_string(step) + ": " + cand.label, &archive, off);
}

// The selected candidate's fit polished again: a fresh simplex from its best point (first
// steps 0.05, the Jacobian's: those points are in the run cache) with the same budget,
// repeated while a restart gains at least 1 % of chi2 and the misfit is above what the
// noise leaves (chi2 > n - q, the mean of chi2 with n - q degrees of freedom), at most twice.
// A profile's polish stops on its run budget, not on convergence (the rate test's step 1:
// chi2 12.5, where its own minimum is below 5); the selected fit is the model carried on,
// so its error is reported converged, and the next step's bound (its BIC floor) sees it.
FitResult polish_selected(const Config& current, const StepCandidate& cand, FitResult f, const ObservationSet& data,
                          const CalibrateOptions& opt) {
  const int q = static_cast<int>(f.names.size());
  for (int restart = 0; restart < 2 && f.chi2 > f.n - q; ++restart) {
    Config c = current;
    apply_effect(c, cand.material, cand.effect->name);
    for (size_t j = 0; j < f.names.size(); ++j) set_param(c, f.names[j], f.values[j]);
    CalibrateOptions po = opt;
    po.max_runs = 6 + 5 * q;
    po.simplex_steps.assign(f.names.size(), 0.05);
    const FitResult g = calibrate(c, data, f.names, po);
    log::info("diagnose:   '" + cand.label + "' polished again: chi2 " + fmt_g(f.chi2) + " -> " +
              fmt_g(std::min(f.chi2, g.chi2)) + " (" + std::to_string(g.runs) + " runs)");
    const int runs = f.runs + g.runs;
    const double before = f.chi2;
    if (g.chi2 < before) f = g;
    f.runs = runs;
    if (!(before - f.chi2 >= 0.01 * before)) break;  // no gain, or under 1 %
  }
  return f;
}

// One step of the diagnosis: the model at its start, every candidate refitted on top of
// it, and the one selected (-1: none earned its parameters).
struct DiagnosisStep {
  FitResult start;
  std::vector<std::pair<StepCandidate, FitResult>> fits;
  int chosen = -1;
  // A step not run because no candidate could be selected: the lowest BIC any candidate could
  // reach (its parameters times ln n, with chi2 = 0); NaN for a step that was run.
  double bic_floor = std::numeric_limits<double>::quiet_NaN();
};

// How far a candidate's fit lowers BIC below the current model's: the current fit's BIC, or
// for an emulated candidate with an "off" face the current model on the candidate's emulator.
double bic_below_start(const FitResult& current, const FitResult& f) {
  if (std::isfinite(f.nested_deviance))
    return f.nested_deviance + static_cast<double>(current.names.size()) * std::log(static_cast<double>(f.n)) - f.bic();
  return current.bic() - f.bic();
}

std::string join_labels(const std::vector<std::string>& labels) {
  if (labels.empty()) return "none";
  std::string s;
  for (size_t i = 0; i < labels.size(); ++i) s += (i ? " + " : "") + labels[i];
  return s;
}
}  // namespace

void check_target_materials(const ObservationSet& data, const Config& scenario) {
  for (const auto& m : data.target_materials) {
    bool known = false;
    for (const auto& mm : scenario.materials) known = known || mm.name == m;
    if (!known) {
      std::string allowed;
      for (const auto& mm : scenario.materials) allowed += (allowed.empty() ? "" : ", ") + mm.name;
      throw DeckError(data.file + ": target_material = \"" + m + "\" is not a material of " + data.scenario +
                      "; allowed: " + allowed);
    }
  }
  auto check = [&](const std::vector<std::string>& names, const char* key, const std::vector<EffectCandidate>& catalogue,
                   const char* what) {
    std::string allowed;
    for (const auto& c : catalogue) allowed += (allowed.empty() ? "" : ", ") + c.name;
    for (size_t i = 0; i < names.size(); ++i) {
      bool known = false;
      for (const auto& c : catalogue) known = known || c.name == names[i];
      if (!known)
        throw DeckError(data.file + ": " + key + "[" + std::to_string(i) + "] = \"" + names[i] + "\" is not a known " +
                        what + "; allowed: " + allowed);
    }
  };
  check(data.effects, "effects", effect_catalogue(), "effect");
  check(data.model_switches, "model_switches", model_switch_catalogue(), "model switch");
}

std::vector<DiagnosisCandidate> diagnosis_candidates(const ObservationSet& data, const Config& base) {
  std::vector<DiagnosisCandidate> out;
  auto label = [&](const EffectCandidate& e, const std::string& m) {
    return data.target_materials.size() > 1 ? e.name + " (" + m + ")" : e.name;
  };
  for (const auto& m : data.target_materials) {
    double su = 0;  // the material's strength c (Su of a Tresca clay; 0 for a cohesionless charge)
    for (const auto& mm : base.materials)
      if (mm.name == m) su = mm.cohesion;
    for (const auto& e : effect_catalogue()) {
      if (data.has_effects && std::find(data.effects.begin(), data.effects.end(), e.name) == data.effects.end())
        continue;
      if (e.scales_strength && !(su > 0)) {
        log::info("diagnose: the effect '" + e.name + "' is not tried on '" + m +
                  "' (it scales the strength c, which is 0 there)");
        continue;
      }
      out.push_back({&e, m, label(e, m)});
    }
    for (const auto& e : model_switch_catalogue()) {
      if (std::find(data.model_switches.begin(), data.model_switches.end(), e.name) == data.model_switches.end())
        continue;
      if (su > 0)
        out.push_back({&e, m, label(e, m)});
      else
        log::info("diagnose: the model switch '" + e.name + "' is not tried on '" + m +
                  "' (its Su is 0: no strength for " + e.strength + " to start from)");
    }
  }
  return out;
}

std::string diagnose(const ObservationSet& data, const std::string& out_dir, const DiagnoseOptions& opt0) {
  if (opt0.max_steps < 1)
    throw std::invalid_argument("diagnose: max_steps " + std::to_string(opt0.max_steps) + "; allowed: 1 or more");
  if (opt0.method != "emulator" && opt0.method != "profile")
    throw std::invalid_argument("diagnose: method '" + opt0.method + "'; allowed: emulator, profile");
  DiagnoseOptions opt = opt0;
  fs::create_directories(out_dir);
  if (opt.fit.scratch.empty()) opt.fit.scratch = out_dir + "/scratch";
  std::unique_ptr<ForwardRuns> own_runner;
  if (!opt.fit.runner) {
    ForwardRunOptions fo;
    fo.jobs = opt.jobs;
    const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    fo.threads_per_job = std::max(1, cores / std::max(1, opt.jobs));
    fo.scratch = opt.fit.scratch;
    fo.cache = out_dir + "/cache";
    fo.tamp_binary = opt.tamp_binary;
    fo.timeout_s = opt.run_timeout_s;
    own_runner = std::make_unique<ForwardRuns>(fo);
    opt.fit.runner = own_runner.get();
  }
  ForwardRuns& runner = *opt.fit.runner;
  const auto wall0 = std::chrono::steady_clock::now();
  if (opt.baseline_params.empty()) opt.baseline_params = {data.target_material + ".Su"};
  const Config base = load_deck(data.scenario, data.scenario_overrides);
  check_target_materials(data, base);
  std::vector<StepCandidate> remaining = diagnosis_candidates(data, base);
  // The parameter each profile refits with the effect: the baseline's strength, or after a
  // model switch of its material the new model's strength key.
  std::string refit_param = opt.baseline_params[0];
  log::info("diagnose: baseline fit of " + std::to_string(opt.baseline_params.size()) + " parameter(s)");
  // baseline: a coarse scan (factors 0.5-2 of the deck values), then Nelder-Mead
  const bool emulated = opt.method == "emulator";
  FitResult baseline0;
  RunArchive archive;                     // every run of the diagnosis, for the later steps' designs
  std::vector<ParameterRange> baseline_box;  // the baseline's parameters within a factor 2 of the deck's values
  if (emulated) {
    for (const auto& p : opt.baseline_params) {
      const double v = get_param(base, p);
      baseline_box.push_back({p, 0.5 * v, 2.0 * v, "the deck's value within a factor 2"});
    }
    baseline0 = calibrate_emulated(base, data, baseline_box, opt.emulator, runner, "baseline", &archive);
  } else {
    baseline0 = scan_then_polish(base, data, opt.baseline_params, {0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0}, 0.1,
                                 10 + 8 * static_cast<int>(opt.baseline_params.size()), opt.fit);
  }
  // The steps: every remaining candidate refitted on top of the current model; the one that
  // lowers BIC most, by more than the margin, joins it; stop when none does.
  std::vector<DiagnosisStep> steps;
  FitResult current = baseline0;
  Config current_cfg = base;
  std::vector<std::string> labels;
  double error_before = baseline0.error;
  for (int k = 0; k < opt.max_steps && !remaining.empty(); ++k) {
    for (size_t j = 0; j < current.names.size(); ++j) set_param(current_cfg, current.names[j], current.values[j]);
    DiagnosisStep st;
    // A step that no candidate can win is not run. A candidate fitted with q parameters has
    // BIC = chi2 + q ln n >= q ln n, and it is selected only below the current BIC minus the
    // margin; when the current fit is already that close to chi2 = 0 (its misfit within what
    // the noise and q more parameters explain), the refits could only confirm "none". Exact:
    // the selection is the one the refits would give (only the fair comparison's side effect,
    // a better start found at a candidate's values, is not sought).
    double bic_floor = std::numeric_limits<double>::infinity();
    for (const auto& cand : remaining) {
      Config c = current_cfg;
      apply_effect(c, cand.material, cand.effect->name);
      bic_floor = std::min(bic_floor, static_cast<double>(candidate_params(c, current.names, cand, emulated).size()) *
                                  std::log(static_cast<double>(current.n)));
    }
    if (!(bic_floor < current.bic() - opt.bic_margin)) {
      if (k == 0) error_before = current.error;
      st.start = current;
      st.bic_floor = bic_floor;
      log::info("diagnose: step " + std::to_string(k + 1) + " not run: no candidate can lower BIC " +
                fmt_g(current.bic()) + " by " + fmt_g(opt.bic_margin) + " (each has BIC >= " + fmt_g(bic_floor) +
                ", its parameters times ln n)");
      steps.push_back(st);
      break;
    }
    // the candidates' fits side by side: their batches merged, so that the simplex moves of
    // one share the workers with the others' (the answers of one fit after the other)
    log::info("diagnose: step " + std::to_string(k + 1) + ", " + std::to_string(remaining.size()) +
              " candidates refitted side by side" + (labels.empty() ? std::string() : " on top of " + join_labels(labels)));
    // With two decks every candidate is first screened (the cheap deck and the pairs run so
    // far, no full run); full runs go only to the contenders: the screened fits that lower BIC
    // by more than the margin and come within the margin of the best. Only a candidate
    // confirmed on the full deck can be selected.
    const bool two_decks = emulated && !opt.emulator.cheap_overrides.empty();
    DiagnoseOptions screening = opt;
    screening.emulator.screen = two_decks;
    std::vector<FitResult> refits(remaining.size());
    runner.side_by_side(remaining.size(), [&](size_t i) {
      CalibrateOptions inner = opt.fit;
      inner.verbose = false;
      refits[i] = emulated
                      ? emulated_candidate_fit(current_cfg, current.names, remaining[i], data, screening, k + 1, baseline_box, archive)
                      : profile_fit(current_cfg, current.names, refit_param, remaining[i], data, inner);
    });
    if (two_decks) {
      double lead = -std::numeric_limits<double>::infinity();
      for (const auto& f : refits) lead = std::max(lead, bic_below_start(current, f));
      std::vector<size_t> contenders;
      for (size_t i = 0; i < refits.size(); ++i) {
        const double b = bic_below_start(current, refits[i]);
        if (b > opt.bic_margin && b >= lead - opt.bic_margin) contenders.push_back(i);
      }
      log::info("diagnose: step " + std::to_string(k + 1) + ": " + std::to_string(contenders.size()) + " of " +
                std::to_string(refits.size()) + " screened candidates go on to the full deck");
      runner.side_by_side(contenders.size(), [&](size_t c) {
        const size_t i = contenders[c];
        refits[i] = emulated_candidate_fit(current_cfg, current.names, remaining[i], data, opt, k + 1, baseline_box, archive);
      });
    }
    for (size_t i = 0; i < remaining.size(); ++i) st.fits.emplace_back(remaining[i], refits[i]);
    // Fair comparison: the current model at each candidate's values of its own parameters;
    // if one fits better than the current fit, it is the current fit (so an effect is not
    // credited with what a better strength alone achieves).
    // The points are run as one batch; only one that fits better is fitted again (its point
    // from the cache, plus its Jacobian for the uncertainty).
    // (Not for a model switch: its parameters are not the current model's. Not for fits on
    // emulators: the current fit is the optimum of a smooth emulator of the current model, and
    // a single run's chi2 beside it would compare the simulator's jitter, not the fits.)
    std::vector<Config> probes;
    std::vector<size_t> probed_fit;
    for (size_t i = 0; i < st.fits.size() && !emulated; ++i) {
      const auto& [cand, f] = st.fits[i];
      if (!cand.effect->model.empty()) continue;
      Config c = current_cfg;
      for (size_t j = 0; j < current.names.size(); ++j) set_param(c, f.names[j], f.values[j]);
      probes.push_back(c);
      probed_fit.push_back(i);
    }
    const auto probed = runner.run(probes);
    for (size_t q = 0; q < probes.size(); ++q) {
      const size_t i = probed_fit[q];
      const StepCandidate& cand = st.fits[i].first;
      if (!(chi2_of(data, probed[q]) < current.chi2)) continue;
      CalibrateOptions probe = opt.fit;
      probe.max_runs = 1 + static_cast<int>(current.names.size());  // the point itself (+ its Jacobian)
      probe.simplex_steps.assign(current.names.size(), 1e-6);
      const FitResult b = calibrate(probes[q], data, current.names, probe);
      if (b.chi2 < current.chi2) {
        log::info("diagnose: the current model at the '" + cand.label + "' fit's values fits better (chi2 " +
                  fmt_g(b.chi2) + " < " + fmt_g(current.chi2) + "): it becomes the current fit");
        const int runs = current.runs + b.runs;
        current = b;
        current.runs = runs;
        for (size_t j = 0; j < current.names.size(); ++j) set_param(current_cfg, current.names[j], current.values[j]);
      }
    }
    if (k == 0) error_before = current.error;
    st.start = current;
    // Selection: the largest fall of BIC below the start, by more than the margin. The start
    // a candidate is measured against is, where it has one, the current model read on the
    // candidate's own emulator (its "off" face): both sides of the comparison then come from
    // one emulator, so that the emulators' different estimates of the jitter do not count.
    double best = opt.bic_margin;
    for (size_t i = 0; i < st.fits.size(); ++i)
      if (!st.fits[i].second.screened && bic_below_start(current, st.fits[i].second) > best) {
        best = bic_below_start(current, st.fits[i].second);
        st.chosen = static_cast<int>(i);
      }
    if (st.chosen >= 0 && !emulated) {  // (an emulated fit is converged by its confirmation rounds)
      auto& [sel, fit] = st.fits[static_cast<size_t>(st.chosen)];
      fit = polish_selected(current_cfg, sel, fit, data, opt.fit);
    }
    steps.push_back(st);
    if (st.chosen < 0) break;
    const auto& [cand, f] = steps.back().fits[static_cast<size_t>(st.chosen)];
    log::info("diagnose: step " + std::to_string(k + 1) + " selects '" + cand.label + "' (BIC " + fmt_g(f.bic()) +
              " against " + fmt_g(current.bic()) + "), error " + fmt_g(current.error, "%.3f") + " -> " +
              fmt_g(f.error, "%.3f"));
    labels.push_back(cand.label);
    apply_effect(current_cfg, cand.material, cand.effect->name);
    current = f;
    const bool switched = !cand.effect->model.empty();
    if (switched && !has_param(current_cfg, refit_param)) refit_param = cand.material + "." + cand.effect->strength;
    // What no longer applies: the selected candidate; after a model switch every other candidate
    // on its material (the effects compose with Mohr-Coulomb/Tresca only, docs/effects.md);
    // after an effect, the model switches of its material (they would drop the effect).
    std::vector<StepCandidate> left;
    for (const auto& c : remaining) {
      const bool same = c.effect == cand.effect && c.material == cand.material;
      const bool excluded = c.material == cand.material && (switched || !c.effect->model.empty());
      if (!same && !excluded) left.push_back(c);
    }
    remaining = left;
  }
  const std::string selected = join_labels(labels);
  const FitResult& baseline = steps.front().start;  // the baseline after the fair comparison of step 1
  const FitResult* chosen = &current;

  nlohmann::ordered_json js;
  js["data"] = data.file;
  js["selected_effect"] = selected;
  js["error_before"] = error_before;
  js["error_after"] = chosen->error;
  js["bic_margin"] = opt.bic_margin;
  js["target_materials"] = data.target_materials;
  js["scenario_overrides"] = data.scenario_overrides;
  js["effects"] = nlohmann::ordered_json::array();
  for (const auto& e : effect_catalogue())
    if (!data.has_effects || std::find(data.effects.begin(), data.effects.end(), e.name) != data.effects.end())
      js["effects"].push_back(e.name);
  js["model_switches"] = data.model_switches;
  const UnexplainedResidual left = unexplained_residual(chosen->residuals, 2.0, static_cast<int>(chosen->names.size()));
  {
    nlohmann::ordered_json u;
    u["remains"] = left.remains;
    u["threshold"] = left.threshold;
    u["error_after"] = left.error;
    u["chi2"] = left.chi2;
    u["degrees_of_freedom"] = left.dof;
    u["p_value"] = left.p_value;
    u["p_min"] = left.p_min;
    u["pattern"] = nlohmann::ordered_json::array();
    for (const UnexplainedGroup& g : left.groups)
      u["pattern"].push_back({{"quantity", g.quantity}, {"blows", g.blows}, {"model_above", g.above},
                              {"model_below", g.below}, {"largest_residual", g.largest}});
    u["text"] = left.text();
    js["unexplained_residual"] = u;
  }
  js["forward_runs"] = {{"run", runner.runs()},
                        {"from_cache", runner.cache_hits()},
                        {"failed", runner.failures()},
                        {"jobs", runner.options().jobs},
                        {"threads_per_job", runner.options().threads_per_job},
                        {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count()}};
  js["forward_runs"]["ranks"] = ranks().size;
  if (emulated) {
    js["forward_runs"]["full_deck_runs"] = archive.full_runs();
    js["forward_runs"]["cheap_deck_runs"] = archive.cheap_runs();
    js["forward_runs"]["cheap_to_full_cost"] = archive.cost_ratio();
    js["forward_runs"]["default_deck_run_equivalents"] = archive.default_deck_equivalents();
  }
  {
    // the shape of the work: batches by their number of runs to do, and the rounds of runs
    // it takes on W workers (each round one run time): what the wall time scales with
    nlohmann::ordered_json shape = nlohmann::ordered_json::object(), rounds = nlohmann::ordered_json::object();
    for (const auto& [size, count] : runner.batch_sizes()) shape[std::to_string(size)] = count;
    for (long w : {1L, 2L, 4L, 8L, 16L, 32L, 64L, 128L}) {
      long r = 0;
      for (const auto& [size, count] : runner.batch_sizes()) r += count * ((size + w - 1) / w);
      rounds[std::to_string(w)] = r;
    }
    js["forward_runs"]["batches_by_size"] = shape;
    js["forward_runs"]["rounds_on_workers"] = rounds;
  }
  js["baseline"] = fit_json("none", baseline);
  // the effects selected before step k + 1 ("none" before the first)
  auto selected_before = [&](size_t k) {
    return join_labels(std::vector<std::string>(labels.begin(), labels.begin() + static_cast<long>(k)));
  };
  // the path: per step the model it started from, every candidate tried, the one selected
  js["path"] = nlohmann::ordered_json::array();
  for (size_t k = 0; k < steps.size(); ++k) {
    const DiagnosisStep& st = steps[k];
    nlohmann::ordered_json p;
    p["step"] = k + 1;
    p["selected"] = st.chosen < 0 ? std::string("none") : st.fits[static_cast<size_t>(st.chosen)].first.label;
    p["material"] = st.chosen < 0 ? std::string() : st.fits[static_cast<size_t>(st.chosen)].first.material;
    p["start"] = fit_json(selected_before(k), st.start);
    if (!std::isnan(st.bic_floor))  // not run: no candidate could be selected
      p["not_run"] = {{"bic_floor", st.bic_floor},
                      {"start_bic", st.start.bic()},
                      {"bic_margin", opt.bic_margin},
                      {"why", "every candidate's BIC is at least its parameters times ln n (chi2 = 0), not below "
                              "the start's BIC minus the margin"}};
    if (st.chosen >= 0) {
      const auto& [cand, fit] = st.fits[static_cast<size_t>(st.chosen)];
      p["fit"] = fit_json(cand.label, fit);
    }
    p["candidates"] = nlohmann::ordered_json::array();
    for (const auto& [cand, fit] : st.fits) {
      auto cj = fit_json(cand.label, fit);
      cj["material"] = cand.material;
      cj["kind"] = cand.effect->model.empty() ? "effect" : "model switch";
      cj["bic_below_start"] = bic_below_start(st.start, fit);
      p["candidates"].push_back(cj);
    }
    js["path"].push_back(p);
  }
  if (ranks().rank > 0) return selected;  // under MPI rank 0 writes the results
  std::ofstream(out_dir + "/diagnosis.json") << js.dump(2) << "\n";

  std::ofstream md(out_dir + "/report.md");
  md << "# Diagnosis of " << data.file << "\n\nScenario: `" << data.scenario << "`";
  for (size_t i = 0; i < data.scenario_overrides.size(); ++i)
    md << (i ? ", `" : " with `") << data.scenario_overrides[i] << "`";
  md << ", target material(s) `" << join_labels(data.target_materials) << "`, " << data.observations.size()
     << " observations.\n\n"
     << "## Baseline (Mohr-Coulomb/Tresca) fit\n\n";
  for (size_t j = 0; j < baseline.names.size(); ++j)
    md << "- " << baseline.names[j] << " = " << fmt_g(baseline.values[j]) << " +- " << fmt_g(baseline.sigmas[j]) << "\n";
  md << "\n" << residual_table(baseline.residuals);
  auto row = [&](const std::string& name, const FitResult& f) {
    std::string ps;
    for (size_t j = 0; j < f.names.size(); ++j)
      ps += (j ? "; " : "") + f.names[j] + " = " + fmt_g(f.values[j]) + " +- " + fmt_g(f.sigmas[j]);
    const auto hv = f.outputs.summary.count("heave_volume_m3") ? f.outputs.summary.at("heave_volume_m3") : 0.0;
    const auto av = f.outputs.summary.count("aggregate_volume_below_ground_m3")
                        ? f.outputs.summary.at("aggregate_volume_below_ground_m3") : 0.0;
    md << "| " << name << " | " << ps << " | " << fmt_g(f.chi2) << " | " << fmt_g(f.error, "%.3f") << " | "
       << fmt_g(f.bic()) << " | " << f.runs << " | " << (av > 0 ? fmt_g(hv / av, "%.3f") : std::string("n/a")) << " |\n";
  };
  for (size_t k = 0; k < steps.size(); ++k) {
    const DiagnosisStep& st = steps[k];
    md << "\n## Step " << k + 1 << ": candidates on top of "
       << (k == 0 ? std::string("the baseline") : selected_before(k))
       << " (BIC = chi2 + k ln n; selected when it lowers BIC by more than " << opt.bic_margin << ")\n\n"
       << "| model | parameters | chi2 | error (RMS) | BIC | forward runs | heave / column volume |\n|---|---|---|---|---|---|---|\n";
    row(k == 0 ? std::string("none (baseline)") : "start", st.start);
    for (const auto& [cand, f] : st.fits) row(cand.label, f);
    if (!std::isnan(st.bic_floor))
      md << "\nNot run: every candidate would have BIC >= " << fmt_g(st.bic_floor)
         << " (its parameters times ln n, with chi2 = 0), not below the start's " << fmt_g(st.start.bic()) << " minus "
         << opt.bic_margin << ": the start's misfit is within what the noise explains, and no candidate can earn "
         << "its parameters.\n";
    md << "\n"
       << (st.chosen < 0 ? std::string("No candidate earns its parameters: the diagnosis stops.")
                         : "Selected: **" + st.fits[static_cast<size_t>(st.chosen)].first.label + "**, error " +
                               fmt_g(st.start.error, "%.3f") + " -> " +
                               fmt_g(st.fits[static_cast<size_t>(st.chosen)].second.error, "%.3f") + ".")
       << "\n";
  }
  md << "\n**Selected: " << selected << "**. Error before " << fmt_g(error_before, "%.3f") << ", after "
     << fmt_g(chosen->error, "%.3f") << ".\n\nThe heave / column volume ratio is the volume balance: an undrained "
     << "(incompressible) soil heaves by the volume of the aggregate pushed into it (ratio near 1); a soil that "
     << "compacts heaves less.\n\n";
  if (emulated) {
    md << "Fits on emulators (docs/closing-the-loop.md \"Emulators\"): the model column is the emulators' mean at "
       << "the fit and the normalised residual is divided by sqrt(sigma^2 + their predictive variance); the "
       << "confirmation runs' own values are in diagnosis.json. Forward runs: " << archive.full_runs()
       << " of the full deck";
    if (archive.cheap_runs() > 0)
      md << ", " << archive.cheap_runs() << " of the cheap deck (cost ratio " << fmt_g(archive.cost_ratio(), "%.3f")
         << "): " << fmt_g(archive.default_deck_equivalents(), "%.1f") << " default-deck run equivalents";
    md << ".\n\n";
  }
  md << "## Residuals after the selected fit\n\n"
     << residual_table(chosen->residuals) << "\n## What the catalogue does not explain\n\n" << left.text()
     << ".\n\n## Traces of the baseline fit\n\n" << trace_report(baseline.outputs)
     << "## Traces of the selected fit\n\n" << trace_report(chosen->outputs);
  if (left.remains) log::warn("diagnose: " + left.text());
  log::info("diagnose: selected '" + selected + "', error before " + fmt_g(error_before, "%.3f") + ", after " +
            fmt_g(chosen->error, "%.3f") + "; " + std::to_string(runner.runs()) + " forward runs (" +
            std::to_string(runner.cache_hits()) + " more from the cache, " + std::to_string(runner.failures()) +
            " failed); " + out_dir + "/diagnosis.json");
  return selected;
}

// ------------------------------------------------------------------ synthetic data

void synthesise(const Config& cfg, const std::string& deck_path_as_written, const std::string& target_material,
                double noise, unsigned seed, const std::string& out_path, const std::string& scratch_dir,
                const std::string& description) {
  const RunOutputs run = run_forward(cfg, scratch_dir);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  ObservationSet set;
  set.scenario_as_written = deck_path_as_written;
  set.target_material = target_material;
  set.target_materials = {target_material};
  auto add = [&](const std::string& q, int blow, double v, double floor) {
    Observation o;
    o.quantity = q;
    o.blow = blow;
    o.sigma = std::max(noise * std::fabs(v), floor);
    o.value = v + o.sigma * normal(rng);
    o.source = "synthetic: " + description;
    set.observations.push_back(o);
  };
  for (size_t b = 0; b < run.blows.size(); ++b) {
    add("crater_depth_m", static_cast<int>(b + 1), run.blows[b].at("crater_depth_m"), 1e-3);
    add("peak_deceleration_m_s2", static_cast<int>(b + 1), run.blows[b].at("peak_deceleration_m_s2"), 1.0);
  }
  add("uplift_m", 0, run.summary.at("uplift_m"), 1e-3);
  if (run.summary.at("aggregate_total_kg") > 0) add("aggregate_total_kg", 0, run.summary.at("aggregate_total_kg"), 0.01);
  std::ostringstream head;
  head << "Synthetic data made by `tamp synth` (" << description << "), relative noise " << noise << ", seed " << seed
       << ".\nUncertainty sigma = max(noise * |value|, floor); floors 1 mm, 1 m/s2, 0.01 kg.";
  write_observations(out_path, set, head.str());
}

}  // namespace tamp
