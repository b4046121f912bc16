// Data files of the closed loop: TOML -> ObservationSet (validated), and back.
#include "core/Observations.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

#include "core/Deck.hpp"
#include "core/Format.hpp"
#include "core/RunSummary.hpp"

namespace tamp {

const std::vector<std::string>& summary_quantities() {  // the observable keys of summary.json
  static const std::vector<std::string> q = [] {
    std::vector<std::string> v;
    for (const auto& f : run_summary_fields())
      if (f.observable) v.push_back(f.key);
    return v;
  }();
  return q;
}

const std::vector<std::string>& per_blow_quantities() {
  static const std::vector<std::string> q{"crater_depth_m", "penetration_m", "peak_deceleration_m_s2", "uplift_m",
                                          "aggregate_added_kg"};
  return q;
}

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

bool contains(const std::vector<std::string>& v, const std::string& x) {
  for (const auto& e : v)
    if (e == x) return true;
  return false;
}

}  // namespace

ObservationSet load_observations(const std::string& path) {
  const std::string shown = printable(path);  // the file name as a one-line message shows it
  namespace fs = std::filesystem;
  require_regular_file(path, "data file");
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw DeckError(shown + ": TOML syntax error at line " + std::to_string(e.source().begin.line) + ": " +
                    std::string(e.description()));
  }
  auto bad = [&](const std::string& key, const std::string& value, const std::string& problem, const std::string& allowed) {
    throw DeckError(shown + ": " + key + " = " + value + " " + problem + "; allowed: " + allowed);
  };
  for (const auto& [k, v] : root)
    if (k.str() != "scenario" && k.str() != "observations" && k.str() != "target_material" &&
        k.str() != "model_switches" && k.str() != "effects")
      bad(std::string(k.str()), "...", "is not a known key",
          "scenario, target_material, effects, model_switches, observations");
  ObservationSet set;
  set.file = path;
  const auto scen = root["scenario"].value<std::string>();
  if (!scen) throw DeckError(shown + ": scenario is missing; required: the path of the scenario deck (relative to this file)");
  set.scenario_as_written = *scen;
  const fs::path sp(*scen);
  set.scenario = sp.is_absolute() ? sp.string() : (fs::path(path).parent_path() / sp).lexically_normal().string();
  if (const auto* node = root.get("target_material")) {
    set.target_materials.clear();
    if (auto t = node->value<std::string>()) set.target_materials.push_back(*t);
    if (const auto* list = node->as_array())
      for (size_t i = 0; i < list->size(); ++i) {
        const auto t = list->get(i)->value<std::string>();
        if (!t || t->empty())
          bad("target_material[" + std::to_string(i) + "]", "...", "is not a material name", "a string naming a material of the scenario");
        for (const auto& seen : set.target_materials)
          if (seen == *t) bad("target_material", "\"" + *t + "\"", "is named twice", "each material once");
        set.target_materials.push_back(*t);
      }
    if (set.target_materials.empty())
      bad("target_material", "...", "names no material", "a material name or a non-empty list of them");
    set.target_material = set.target_materials.front();
  }
  // Lists of names (effects, model switches): strings, each once; the names are checked
  // against the catalogues by the diagnosis (check_target_materials).
  auto names = [&](const char* key, const std::string& example, std::vector<std::string>& out) {
    const auto* node = root.get(key);
    if (!node) return false;
    const auto* list = node->as_array();
    if (!list) bad(key, "...", "has the wrong type", "a list of names, e.g. [" + example + "]");
    for (size_t i = 0; i < list->size(); ++i) {
      const auto t = list->get(i)->value<std::string>();
      if (!t || t->empty()) bad(std::string(key) + "[" + std::to_string(i) + "]", "...", "is not a name", "a string");
      for (const auto& seen : out)
        if (seen == *t) bad(key, "\"" + printable(*t) + "\"", "is named twice", "each name once");
      out.push_back(*t);
    }
    return true;
  };
  names("model_switches", "\"modified-cam-clay\"", set.model_switches);
  set.has_effects = names("effects", "\"compaction\", \"rate\"", set.effects);
  const auto* arr = root["observations"].as_array();
  if (!arr || arr->empty()) throw DeckError(shown + ": observations is missing; required: at least one [[observations]] entry");
  for (size_t i = 0; i < arr->size(); ++i) {
    const std::string p = "observations[" + std::to_string(i) + "]";
    const auto* t = arr->get(i)->as_table();
    if (!t) bad(p, "...", "has the wrong type", "a table ([[observations]])");
    for (const auto& [k, v] : *t) {
      const std::string key(k.str());
      if (key != "quantity" && key != "blow" && key != "value" && key != "sigma" && key != "range" && key != "source")
        bad(p + "." + key, "...", "is not a known key", "quantity, blow, value, sigma, range, source");
    }
    Observation o;
    const auto q = (*t)["quantity"].value<std::string>();
    if (!q) throw DeckError(shown + ": " + p + ".quantity is missing; required: one of " + join(summary_quantities()) +
                            " or, with blow = N, " + join(per_blow_quantities()));
    o.quantity = *q;
    if (const auto* b = t->get("blow")) {
      const auto bi = b->value<int64_t>();
      if (!bi || *bi < 1 || *bi > 1000000) bad(p + ".blow", bi ? std::to_string(*bi) : "...", "is out of range", "an integer 1 to 1000000");
      o.blow = static_cast<int>(*bi);
      if (!contains(per_blow_quantities(), o.quantity))
        bad(p + ".quantity", "\"" + printable(o.quantity) + "\"", "is not a per-blow quantity", join(per_blow_quantities()));
    } else if (!contains(summary_quantities(), o.quantity)) {
      bad(p + ".quantity", "\"" + printable(o.quantity) + "\"", "is not a known quantity",
          join(summary_quantities()) + " (or with blow = N: " + join(per_blow_quantities()) + ")");
    }
    const auto* range = t->get("range");
    const auto value = (*t)["value"].value<double>();
    const auto sigma = (*t)["sigma"].value<double>();
    for (const char* k : {"value", "sigma"})  // present, then a number (an integer reads as one)
      if (const auto* node = t->get(k); node && !node->is_number()) {
        std::ostringstream v;
        node->visit([&](const auto& n) { v << n; });
        bad(p + "." + k, printable(v.str(), 60), "has the wrong type", "a finite number");
      }
    if (range) {
      const auto* ra = range->as_array();
      if (!ra || ra->size() != 2 || !ra->get(0)->value<double>() || !ra->get(1)->value<double>())
        bad(p + ".range", "...", "has the wrong form", "[low, high] with low < high");
      o.lo = *ra->get(0)->value<double>();
      o.hi = *ra->get(1)->value<double>();
      const std::string shown_range = "[" + fmt_num(o.lo) + ", " + fmt_num(o.hi) + "]";
      if (!std::isfinite(o.lo) || !std::isfinite(o.hi))
        bad(p + ".range", shown_range, "is not finite", "finite numbers [low, high] with low < high");
      if (!(o.lo < o.hi)) bad(p + ".range", shown_range, "is out of range", "low < high");
      if (value || sigma) bad(p + ".value", "...", "conflicts with range", "either range = [low, high] or value and sigma");
      o.is_range = true;
      // halves first: the midpoint and half-width of [1e308, 1.7e308] do not overflow
      o.value = 0.5 * o.lo + 0.5 * o.hi;
      o.sigma = 0.5 * o.hi - 0.5 * o.lo;
      if (!(o.sigma > 0)) bad(p + ".range", shown_range, "is too narrow to be an uncertainty", "low < high with (high - low) / 2 > 0");
    } else {
      if (!value) throw DeckError(shown + ": " + p + ".value is missing; required: value and sigma, or range = [low, high]");
      if (!sigma) throw DeckError(shown + ": " + p + ".sigma is missing; required: sigma > 0 with value");
      if (!std::isfinite(*value)) bad(p + ".value", fmt_num(*value), "is not finite", "a finite number");
      if (!(*sigma > 0) || !std::isfinite(*sigma)) bad(p + ".sigma", fmt_num(*sigma), "is out of range", "a finite sigma > 0");
      o.value = *value;
      o.sigma = *sigma;
    }
    // the normalised residual (model - value) / sigma of a model near the value, and its
    // square in chi2, must stay finite
    if (!(std::fabs(o.value) <= 1e150 * o.sigma))
      bad(p + (o.is_range ? ".range" : ".sigma"), fmt_num(o.sigma) + " (sigma) for " + fmt_num(o.value),
          "is too small beside the value", "sigma >= |value| * 1e-150");
    if (const auto* src = t->get("source")) {
      const auto s = src->value<std::string>();
      if (!s) {
        std::ostringstream v;
        src->visit([&](const auto& node) { v << node; });
        bad(p + ".source", printable(v.str(), 60), "has the wrong type", "a string (where the value comes from)");
      }
      o.source = *s;
    }
    set.observations.push_back(o);
  }
  return set;
}

void write_observations(const std::string& path, const ObservationSet& set, const std::string& header_comment) {
  std::ostringstream o;
  std::istringstream hc(header_comment);
  for (std::string line; std::getline(hc, line);) o << "# " << line << "\n";
  o << "scenario = \"" << set.scenario_as_written << "\"\n";
  if (set.target_materials.size() > 1) {
    o << "target_material = [";
    for (size_t i = 0; i < set.target_materials.size(); ++i) o << (i ? ", " : "") << "\"" << set.target_materials[i] << "\"";
    o << "]\n";
  } else {
    o << "target_material = \"" << set.target_material << "\"\n";
  }
  if (set.has_effects) {
    o << "effects = [";
    for (size_t i = 0; i < set.effects.size(); ++i) o << (i ? ", " : "") << "\"" << set.effects[i] << "\"";
    o << "]\n";
  }
  if (!set.model_switches.empty()) {
    o << "model_switches = [";
    for (size_t i = 0; i < set.model_switches.size(); ++i) o << (i ? ", " : "") << "\"" << set.model_switches[i] << "\"";
    o << "]\n";
  }
  for (const auto& ob : set.observations) {
    o << "\n[[observations]]\nquantity = \"" << ob.quantity << "\"\n";
    if (ob.blow > 0) o << "blow = " << ob.blow << "\n";
    char buf[128];
    if (ob.is_range) {
      std::snprintf(buf, sizeof buf, "range = [%.17g, %.17g]\n", ob.lo, ob.hi);
    } else {
      std::snprintf(buf, sizeof buf, "value = %.17g\nsigma = %.17g\n", ob.value, ob.sigma);
    }
    o << buf;
    if (!ob.source.empty()) o << "source = \"" << ob.source << "\"\n";
  }
  std::ofstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot write the data file");
  f << o.str();
}

}  // namespace tamp
