// The closed loop with measured data (docs/closing-the-loop.md): forward runs of a
// scenario, residuals against observations, calibration (Levenberg-Marquardt), diagnosis
// over the effect catalogue (models/Effects.hpp) ranked by BIC, and synthetic data.
#pragma once
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "core/Config.hpp"
#include "models/EffectCatalogue.hpp"
#include "core/Observations.hpp"

namespace tamp {

// What a forward run gives: the summary.json keys and the blows.csv rows.
struct RunOutputs {
  std::map<std::string, double> summary;
  std::vector<std::map<std::string, double>> blows;  // index blow - 1
};

// Runs a drop-sequence deck to the end in `scratch_dir` (created, replaced) and returns
// its outputs. Quiet (no progress lines).
RunOutputs run_forward(const Config& cfg, const std::string& scratch_dir);
// Reads the outputs of a finished `tamp run` folder (summary.json, blows.csv).
RunOutputs read_run_dir(const std::string& dir);

// A model parameter by name: "<material>.<key>" (key: G, nu, Su, c, phi_deg, density,
// crush_pressure, crush_hardening, air_voids, rate_coefficient, reference_strain_rate,
// remoulded_ratio, remoulding_strain) or "contact.<key>". Throws std::invalid_argument
// naming the parameter and what is allowed.
double get_param(const Config& cfg, const std::string& name);
void set_param(Config& cfg, const std::string& name, double value);
// Whether `name` is a fittable parameter of the deck (of the material's current model).
bool has_param(const Config& cfg, const std::string& name);

struct Residual {
  const Observation* obs;
  double model = 0;       // the model's value (NaN when the run has no such quantity)
  double normalised = 0;  // (model - value) / sigma
};

std::vector<Residual> residuals(const ObservationSet& data, const RunOutputs& run);
double rms(const std::vector<Residual>& r);  // RMS of the normalised residuals
std::string residual_table(const std::vector<Residual>& r);  // Markdown
std::string residuals_json(const std::vector<Residual>& r);

// What a fit leaves unexplained (docs/closing-the-loop.md, "A residual the catalogue does not
// explain"): a residual remains when the error (RMS of the normalised residuals) stays above
// `threshold`, or when the chi-square goodness of fit fails: chi2 this large arises from the
// noise alone with probability p < p_min, on n - fitted_params degrees of freedom. The
// pattern: the observations outside `threshold` uncertainties, grouped by quantity in the
// order of the data file, with the sign of the misfit (model above or below the measurement).
struct UnexplainedGroup {
  std::string quantity;
  std::vector<int> blows;   // the observations' blows (0: a summary quantity)
  int above = 0, below = 0; // model above / below the measurement
  double largest = 0;       // the normalised residual of largest magnitude
};
struct UnexplainedResidual {
  bool remains = false;          // too_large_error or poor_fit
  bool too_large_error = false;  // error > threshold
  bool poor_fit = false;         // p_value < p_min
  double error = 0, threshold = 2;
  double chi2 = 0;
  int dof = 0;                   // observations - fitted parameters
  double p_value = 1, p_min = 0.01;
  std::vector<UnexplainedGroup> groups;  // empty unless remains
  std::string text() const;              // one sentence for the report and the log
};
UnexplainedResidual unexplained_residual(const std::vector<Residual>& r, double threshold = 2.0,
                                         int fitted_params = 0, double p_min = 0.01);

struct FitResult {
  std::vector<std::string> names;
  std::vector<double> values, sigmas;  // best fit and its 1-sigma (linearised) uncertainty
  double chi2 = 0;                     // sum of squared normalised residuals
  double error = 0;                    // RMS of the normalised residuals
  int runs = 0;                        // forward runs used
  int n = 0;                           // observations
  std::vector<Residual> residuals;
  RunOutputs outputs;                  // of the best fit
  // A fit on emulators (calibrate_emulated): the design, the emulators' leave-one-out
  // errors, predicted and confirmed chi2, each parameter's range and identifiability, as a
  // JSON object ("" for a fit by forward runs alone).
  std::string emulator_json;
  bool confirmed = true;               // an emulated fit: its optimum's run confirmed the emulators
  bool screened = false;   // on emulators with two decks: fitted on the cheap deck only (no full run)
  // An emulated candidate with an "off" face: the deviance of the model without the effect,
  // read on the candidate's emulator (NaN otherwise).
  double nested_deviance = std::numeric_limits<double>::quiet_NaN();
  double bic() const;                  // chi2 + k ln n (known uncertainties)
};

class ForwardRuns;  // drivers/loop/ForwardRuns.hpp

struct CalibrateOptions {
  std::string method = "nelder-mead";  // or "lm" (Levenberg-Marquardt with Eigen), or NLopt's
                                       // "sbplx" / "bobyqa" (when built with NLopt)
  int max_iterations = 8;  // LM iterations
  int max_runs = 0;        // Nelder-Mead budget of forward runs; 0 = 12 + 20 per parameter
  std::vector<double> simplex_steps;  // Nelder-Mead first steps in the fitted coordinate (default 0.3)
  double step = 0.05;      // finite-difference step in the transformed parameter (~5 %)
  std::string scratch;     // folder for the forward runs (when `runner` is not given)
  bool verbose = true;
  // Runs the forward runs (side by side, remembered); null: one in this process at a time,
  // in `scratch`, without a cache.
  ForwardRuns* runner = nullptr;
};

// Fits the named parameters, starting from their values in `cfg`: Nelder-Mead (default;
// robust to the small jumps of a particle model's response) or Levenberg-Marquardt.
// Positive parameters are fitted in log space, remoulded_ratio in logit space. The
// uncertainty is linearised from a finite-difference Jacobian at the best point.
FitResult calibrate(const Config& cfg, const ObservationSet& data, const std::vector<std::string>& params,
                    const CalibrateOptions& opt);

// A fitted parameter's range: the box of an emulator's design, with where it comes from.
struct ParameterRange {
  std::string name;  // "<material>.<key>" or "contact.<key>"
  double lo = 0, hi = 0;
  std::string source;
  bool linear = false;  // designed and fitted in the value itself (an effect's strength with its
                        // "off" value at an end: air voids 0, rate coefficient 0, remoulded ratio 1);
                        // else in log (or logit for a fraction)
  double off = -1;      // that "off" value, where the parameter has one in [lo, hi] (else < lo)
};

// The runs of a diagnosis, every fit's, kept so that a later fit whose box holds them reuses
// them (one design serving many candidates: a step's candidate with two effects finds the
// runs of each effect alone on the faces of its box where the other is off). Thread-safe
// (the candidates of a step are fitted side by side).
class RunArchive {
 public:
  void add(const Config& cfg, const RunOutputs& out);
  std::vector<std::pair<Config, RunOutputs>> runs() const;
  // The cost of the runs by fidelity (wall seconds of the batches that ran them, cache hits
  // included at their cost of zero), for the default-deck run equivalents.
  void count(bool cheap, long runs, double wall_s);
  long cheap_runs() const;
  long full_runs() const;
  // full runs + cheap runs x (measured cost of a cheap run / a full one); = runs with one deck
  double default_deck_equivalents() const;
  double cost_ratio() const;  // cheap / full per run (NaN until both have run)

 private:
  mutable std::mutex m_;
  std::vector<std::pair<Config, RunOutputs>> runs_;
  long cheap_runs_ = 0, full_runs_ = 0;
  double cheap_wall_ = 0, full_wall_ = 0;
};

// A deck with every effect that is off written one way (compaction without a crush pressure
// or without air voids; rate without a coefficient; remoulding to a ratio of 1), so that two
// decks that run the same physics compare equal, and a deck at an emulator's "off" face is one
// the deck reader accepts.
Config canonical_effects(Config cfg);

// A fit on emulators (drivers/loop/EmulatedFit.hpp): a maximin Latin hypercube of about
// `points_per_parameter` runs per parameter over `ranges` (in the fitted coordinate: log, or
// logit for a fraction), a Gaussian process per observation, the fit on them, confirmed by
// runs at the emulators' optimum, q = `batch` points per round. `start` (the current
// model's values, already run) joins the design when it lies in the box. `seed_label` seeds
// the design (the same label, the same design). `runs` does the forward runs.
struct EmulatorSettings {
  int points_per_parameter = 10;
  int batch = 2;
  int max_rounds = 4;
  double confirm_z = 3.0;
  double max_latent_share = 1.0;
  // Cheap and full decks together (EmulatedFit.hpp "Two fidelities"): when not empty, these
  // deck overrides (KEY=VALUE, as --set) make the cheap deck that runs the design and the
  // exploration; each round's optimum runs on both, and the fit is the full deck's.
  std::vector<std::string> cheap_overrides;
  // With two decks: fit on the cheap deck and the pairs already run, no full run (a
  // diagnosis's screening of its candidates; EmulatedFitOptions::screen).
  bool screen = false;
};
// `archive`, when given, holds earlier runs: those that are the deck at a point of the box
// (decks compared after canonical_effects) join the design without being run again, and the
// fit's own runs are added to it. `nested_off`: the parameters that, at their "off" value,
// make the model without the candidate (its nested model, read on the same emulators).
FitResult calibrate_emulated(const Config& cfg, const ObservationSet& data, const std::vector<ParameterRange>& ranges,
                             const EmulatorSettings& settings, ForwardRuns& runs, const std::string& seed_label,
                             RunArchive* archive = nullptr, const std::vector<std::string>& nested_off = {});

// The ranges `tamp calibrate --method emulator` designs over: an effect's key over its
// catalogue range (docs/effects.md), any other parameter within a factor 2 of the deck's value.
std::vector<ParameterRange> default_ranges(const Config& cfg, const std::vector<std::string>& names);

// Sets an effect's parameters on `material` ("none" sets nothing), or switches its model
// (a name of model_switch_catalogue()). `overrides` (key=value, material-relative keys)
// replace the catalogue's defaults.
void apply_effect(Config& cfg, const std::string& material, const std::string& effect,
                  const std::map<std::string, double>& overrides = {});

struct DiagnoseOptions {
  std::vector<std::string> baseline_params;  // default: {"<target>.Su"}
  // "profile" (default): the profile grid and simplex polish of every candidate by forward
  // runs alone (fit.method the polish); "emulator": each fit on emulators from a space-filling
  // design, confirmed by runs (calibrate_emulated; docs/closing-the-loop.md "Emulators": not
  // yet the default, it misses the second effect of the two-effect test).
  std::string method = "profile";
  EmulatorSettings emulator;
  // An effect must lower BIC by more than this: 6 = "strong" evidence (Kass & Raftery 1995).
  // With n ~ 10 observations a spurious one-parameter effect then passes only when it lowers
  // chi2 by more than 6 + ln n (~8.3): p ~ 0.4 % per candidate under the null.
  double bic_margin = 6.0;
  CalibrateOptions fit;
  // Forward runs (drivers/loop/ForwardRuns.hpp): this many side by side (child processes of
  // `tamp_binary` when > 1), each run remembered in DIR/cache so that a diagnosis started
  // again in the same folder does not redo them.
  // Effects composed step by step: after one is selected the rest are tried again on top of
  // it; at most this many steps (each adds one effect).
  int max_steps = 3;
  int jobs = 1;
  std::string tamp_binary;
  double run_timeout_s = 0;  // a forward run longer than this is a failed point (0 = no limit)
};

// Throws DeckError (file, key, value, the materials allowed) unless every target material
// of the data file is a material of the scenario.
void check_target_materials(const ObservationSet& data, const Config& scenario);

// One candidate of a diagnosis step: an effect (or model switch) on one target material.
struct DiagnosisCandidate {
  const EffectCandidate* effect;
  std::string material;
  std::string label;  // "compaction", or "compaction (aggregate)" when the data names several targets
};
// The candidates of a diagnosis: every effect of the catalogue (or of the data file's
// `effects`) on every target material, but those that scale a strength the material does not
// have (c = 0), and the model switches the data file asks for on every target material with
// an undrained strength to start from; per material in the data file's order, effects first.
std::vector<DiagnosisCandidate> diagnosis_candidates(const ObservationSet& data, const Config& scenario);

// Calibrates the baseline, then step by step refits with each catalogued effect on each
// target material on top of the model so far, adds the one that lowers BIC most (by more
// than the margin), and stops when none does; writes DIR/diagnosis.json (with the path) and
// DIR/report.md; returns the selected effects joined by " + " ("none" if none earns its
// parameters), e.g. "compaction + remoulding".
std::string diagnose(const ObservationSet& data, const std::string& out_dir, const DiagnoseOptions& opt);

// Synthetic data: runs `cfg` (with whatever effect it carries) and writes the data file
// with relative noise `noise` (sigma = max(noise |value|, floor of the quantity)), seeded.
void synthesise(const Config& cfg, const std::string& deck_path_as_written, const std::string& target_material,
                double noise, unsigned seed, const std::string& out_path, const std::string& scratch_dir,
                const std::string& description);

}  // namespace tamp
