// Input decks: TOML -> validated Config (see Deck.hpp for the layout), Config -> TOML.
#include "core/Format.hpp"
#include "core/Deck.hpp"
#include "core/ParticleGrid.hpp"
#include "core/Range.hpp"
#include "core/MaterialModel.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include <toml++/toml.h>

namespace tamp {
namespace {

// Materials given by unit weight are converted with this g (not the deck's gravity), so
// that a unit weight from a site report always means the same density.
constexpr double kUnitWeightGravity = 9.81;

// ---------------------------------------------------------------- formatting helpers


// As fmt_num, but always a TOML float ("5.0" rather than "5").
std::string fmt_float(double x) {
  std::string s = fmt_num(x);
  if (s.find_first_of(".eEn") == std::string::npos && s.find("inf") == std::string::npos)
    s += ".0";
  return s;
}

// A TOML basic string.
std::string quote(std::string_view s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\t': out += "\\t"; break;
      case '\n': out += "\\n"; break;
      case '\f': out += "\\f"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20 || c == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04X", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

// A key as it would be written in TOML: bare when possible, quoted otherwise.
std::string key_text(std::string_view k) {
  bool bare = !k.empty();
  for (const char c : k)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) bare = false;
  return bare ? std::string(k) : quote(k);
}

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "string";
    case toml::node_type::integer: return "integer";
    case toml::node_type::floating_point: return "float";
    case toml::node_type::boolean: return "boolean";
    case toml::node_type::array: return "array";
    case toml::node_type::table: return "table";
    case toml::node_type::date: return "date";
    case toml::node_type::time: return "time";
    case toml::node_type::date_time: return "date-time";
    default: return "nothing";
  }
}

// The value of a node as the user would have written it (long tables/arrays shortened).
std::string repr(const toml::node& n) {
  std::string s;
  switch (n.type()) {
    case toml::node_type::string: s = quote(n.as_string()->get()); break;
    case toml::node_type::integer: s = std::to_string(n.as_integer()->get()); break;
    case toml::node_type::floating_point: s = fmt_float(n.as_floating_point()->get()); break;
    case toml::node_type::boolean: s = n.as_boolean()->get() ? "true" : "false"; break;
    case toml::node_type::array: {
      s = "[";
      bool first = true;
      for (const auto& e : *n.as_array()) {
        s += (first ? "" : ", ") + repr(e);
        first = false;
      }
      s += "]";
      break;
    }
    case toml::node_type::table: {
      const auto& t = *n.as_table();
      if (t.empty()) {
        s = "{}";
        break;
      }
      s = "{ ";
      bool first = true;
      for (const auto& [k, v] : t) {
        s += (first ? "" : ", ") + key_text(k.str()) + " = " + repr(v);
        first = false;
      }
      s += " }";
      break;
    }
    default: {
      std::ostringstream os;
      n.visit([&os](const auto& v) { os << v; });
      s = os.str();
    }
  }
  constexpr std::size_t max_len = 100;
  if (s.size() > max_len) s = s.substr(0, max_len - 3) + "...";
  return s;
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

// ---------------------------------------------------------------- ranges (core/Range.hpp)

using namespace ranges;

// ---------------------------------------------------------------- error reporting


class Reporter {
 public:
  explicit Reporter(const std::string& file) : file_(printable(file)) {}

  // "<file>: <path> = <value> <problem>; allowed: <allowed>"
  [[noreturn]] void bad(const std::string& path, const std::string& value, const std::string& problem,
                        const std::string& allowed) const {
    throw DeckError(file_ + ": " + path + " = " + value + " " + problem + "; allowed: " + allowed);
  }
  [[noreturn]] void bad(const std::string& path, const toml::node& n, const std::string& problem,
                        const std::string& allowed) const {
    bad(path, repr(n), problem, allowed);
  }
  [[noreturn]] void wrong_type(const std::string& path, const toml::node& n,
                               const std::string& allowed) const {
    bad(path, n, std::string("has the wrong type (") + type_name(n) + ")", allowed);
  }
  [[noreturn]] void out_of_range(const std::string& path, const toml::node& n,
                                 const std::string& allowed) const {
    bad(path, n, "is out of range", allowed);
  }
  // "<file>: <path> is missing; required: <what>"
  [[noreturn]] void missing(const std::string& path, const std::string& what) const {
    throw DeckError(file_ + ": " + path + " is missing; required: " + what);
  }

 private:
  std::string file_;
};

// A TOML table with a fixed set of allowed keys; any other key is an error.
class Table {
 public:
  Table(const Reporter& rep, const toml::table& t, std::string prefix,
        std::initializer_list<const char*> keys)
      : Table(rep, t, std::move(prefix), std::vector<std::string>(keys.begin(), keys.end())) {}
  Table(const Reporter& rep, const toml::table& t, std::string prefix, const std::vector<std::string>& keys)
      : rep_(rep), t_(t), prefix_(std::move(prefix)) {
    for (const auto& [k, v] : t_) {
      bool known = false;
      for (const auto& key : keys) known = known || k.str() == key;
      if (!known) rep_.bad(path(k.str()), v, "is not a known key", join(keys, ", "));
    }
  }

  const Reporter& rep() const { return rep_; }
  const toml::node* find(std::string_view key) const { return t_.get(key); }
  std::string path(std::string_view key) const {
    return prefix_.empty() ? key_text(key) : prefix_ + "." + key_text(key);
  }

 private:
  const Reporter& rep_;
  const toml::table& t_;
  std::string prefix_;
};

// ---------------------------------------------------------------- typed readers

std::optional<double> as_number(const toml::node& n) {
  if (const auto* i = n.as_integer()) return static_cast<double>(i->get());
  if (const auto* f = n.as_floating_point()) return f->get();
  return std::nullopt;
}

std::optional<double> opt_number(const Table& t, std::string_view key, const Range& range,
                                 std::string_view unit) {
  const toml::node* n = t.find(key);
  if (!n) return std::nullopt;
  const std::string allowed = range.text(key, unit);
  const auto x = as_number(*n);
  if (!x) t.rep().wrong_type(t.path(key), *n, "a number, " + allowed);
  if (!std::isfinite(*x)) t.rep().bad(t.path(key), *n, "is not a finite number", allowed);
  if (!range.contains(*x)) t.rep().out_of_range(t.path(key), *n, allowed);
  return x;
}

double number(const Table& t, std::string_view key, double fallback, const Range& range,
              std::string_view unit) {
  return opt_number(t, key, range, unit).value_or(fallback);
}

double required_number(const Table& t, std::string_view key, const Range& range,
                       std::string_view unit) {
  const auto x = opt_number(t, key, range, unit);
  if (!x) t.rep().missing(t.path(key), range.text(key, unit));
  return *x;
}

long long integer(const Table& t, std::string_view key, long long fallback, long long lo,
                  long long hi) {
  const toml::node* n = t.find(key);
  if (!n) return fallback;
  std::string allowed = std::string(key) + " >= " + std::to_string(lo);
  if (hi != LLONG_MAX) allowed = std::to_string(lo) + " <= " + std::string(key) + " <= " + std::to_string(hi);
  const auto* i = n->as_integer();
  if (!i) t.rep().wrong_type(t.path(key), *n, "an integer, " + allowed);
  if (i->get() < lo || i->get() > hi) t.rep().out_of_range(t.path(key), *n, allowed);
  return i->get();
}

bool boolean(const Table& t, std::string_view key, bool fallback) {
  const toml::node* n = t.find(key);
  if (!n) return fallback;
  const auto* b = n->as_boolean();
  if (!b) t.rep().wrong_type(t.path(key), *n, "true or false");
  return b->get();
}

std::optional<std::string> opt_string(const Table& t, std::string_view key,
                                      const std::string& allowed) {
  const toml::node* n = t.find(key);
  if (!n) return std::nullopt;
  const auto* s = n->as_string();
  if (!s) t.rep().wrong_type(t.path(key), *n, allowed);
  return s->get();
}

std::string required_string(const Table& t, std::string_view key, const std::string& allowed) {
  auto s = opt_string(t, key, allowed);
  if (!s) t.rep().missing(t.path(key), allowed);
  return *s;
}

// One of a fixed set of strings.
std::string choice(const Table& t, std::string_view key, const std::vector<std::string>& options,
                   const char* what, std::optional<std::string> fallback) {
  std::vector<std::string> quoted;
  for (const auto& o : options) quoted.push_back(quote(o));
  const std::string allowed = join(quoted, ", ");
  auto s = opt_string(t, key, "a string, one of " + allowed);
  if (!s) {
    if (fallback) return *fallback;
    t.rep().missing(t.path(key), "one of " + allowed);
  }
  for (const auto& o : options)
    if (*s == o) return o;
  t.rep().bad(t.path(key), *t.find(key), std::string("is not a known ") + what, allowed);
}

// [a, b]: an array of exactly two finite numbers.
std::optional<std::array<double, 2>> opt_pair(const Table& t, std::string_view key,
                                              const std::string& shape) {
  const toml::node* n = t.find(key);
  if (!n) return std::nullopt;
  const auto* a = n->as_array();
  if (!a) t.rep().wrong_type(t.path(key), *n, "an array " + shape);
  if (a->size() != 2) t.rep().bad(t.path(key), *n, "has the wrong length", shape);
  std::array<double, 2> out{};
  for (std::size_t j = 0; j < 2; ++j) {
    const std::string p = t.path(key) + "[" + std::to_string(j) + "]";
    const auto x = as_number(*a->get(j));
    if (!x) t.rep().wrong_type(p, *a->get(j), "a number; " + std::string(key) + " = " + shape);
    if (!std::isfinite(*x)) t.rep().bad(p, *a->get(j), "is not a finite number", shape);
    out[j] = *x;
  }
  return out;
}

// A sub-table (standard [a.b] or inline a = { ... }); nullptr when absent.
const toml::table* sub_table(const Table& t, std::string_view key) {
  const toml::node* n = t.find(key);
  if (!n) return nullptr;
  if (!n->is_table())
    t.rep().wrong_type(t.path(key), *n, "a table ([" + t.path(key) + "] or { ... })");
  return n->as_table();
}

// A non-empty array of tables ([[key]]).
std::vector<const toml::table*> table_array(const Table& t, std::string_view key) {
  const std::string p = t.path(key);
  const std::string allowed = "an array of tables, one [[" + p + "]] section per entry";
  const toml::node* n = t.find(key);
  if (!n) t.rep().missing(p, "at least one [[" + p + "]] entry");
  const auto* a = n->as_array();
  if (!a) t.rep().wrong_type(p, *n, allowed);
  if (a->empty()) t.rep().bad(p, *n, "has no entries", "at least one [[" + p + "]] entry");
  std::vector<const toml::table*> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const auto* e = a->get(i)->as_table();
    if (!e) t.rep().wrong_type(p + "[" + std::to_string(i) + "]", *a->get(i), allowed);
    out.push_back(e);
  }
  return out;
}

// A non-empty array of numbers, each in `range`.
std::vector<double> number_array(const Table& t, std::string_view key, const Range& range,
                                 std::string_view unit) {
  const toml::node* n = t.find(key);
  const std::string allowed = "a non-empty array of numbers, each " + range.text("value", unit);
  if (!n) t.rep().missing(t.path(key), allowed);
  const auto* a = n->as_array();
  if (!a) t.rep().wrong_type(t.path(key), *n, allowed);
  if (a->empty()) t.rep().bad(t.path(key), *n, "has no entries", allowed);
  std::vector<double> out;
  for (std::size_t j = 0; j < a->size(); ++j) {
    const std::string p = t.path(key) + "[" + std::to_string(j) + "]";
    const auto x = as_number(*a->get(j));
    if (!x) t.rep().wrong_type(p, *a->get(j), allowed);
    if (!range.contains(*x)) t.rep().out_of_range(p, *a->get(j), range.text("value", unit));
    out.push_back(*x);
  }
  return out;
}

// An array of integers in [lo, hi], strictly increasing (may be empty).
std::vector<int> increasing_int_array(const Table& t, std::string_view key, long long lo, long long hi) {
  const toml::node* n = t.find(key);
  const std::string allowed = "an array of increasing integers, each " + std::to_string(lo) +
                              " <= value <= " + std::to_string(hi);
  std::vector<int> out;
  if (!n) return out;
  const auto* a = n->as_array();
  if (!a) t.rep().wrong_type(t.path(key), *n, allowed);
  for (std::size_t j = 0; j < a->size(); ++j) {
    const std::string p = t.path(key) + "[" + std::to_string(j) + "]";
    const auto* i = a->get(j)->as_integer();
    if (!i) t.rep().wrong_type(p, *a->get(j), allowed);
    if (i->get() < lo || i->get() > hi || (!out.empty() && i->get() <= out.back()))
      t.rep().out_of_range(p, *a->get(j), allowed);
    out.push_back(static_cast<int>(i->get()));
  }
  return out;
}

// ---------------------------------------------------------------- sections

void read_run(const Table& top, RunSpec& run) {
  const toml::table* tt = sub_table(top, "run");
  if (!tt) return;
  const Table t(top.rep(), *tt, "run",
                {"name", "end_time", "output_interval", "cfl", "progress_interval", "max_steps"});
  if (auto name = opt_string(t, "name", "a non-empty string")) {
    if (name->empty()) t.rep().out_of_range(t.path("name"), *t.find("name"), "a non-empty string");
    run.name = *name;
  }
  run.end_time = number(t, "end_time", run.end_time, gt(0), "s");
  run.output_interval = number(t, "output_interval", run.output_interval, ge(0), "s");
  run.cfl = number(t, "cfl", run.cfl, gt_le(0, 1), "");
  run.progress_interval = number(t, "progress_interval", run.progress_interval, gt(0), "s");
  run.max_steps = static_cast<long>(integer(t, "max_steps", run.max_steps, 0, LONG_MAX));
}

void read_sph(const Table& top, SphSpec& sph) {
  const toml::table* tt = sub_table(top, "sph");
  if (!tt) top.rep().missing("sph.spacing", "spacing > 0 (m), the initial particle spacing, in [sph]");
  const Table t(top.rep(), *tt, "sph",
                {"spacing", "h_factor", "alpha", "beta", "artificial_stress", "artificial_stress_n",
                 "regularise_every", "kernel_correction", "neighbour_skin", "axis_radius_factor"});
  sph.spacing = required_number(t, "spacing", gt(0), "m");
  sph.h_factor = number(t, "h_factor", sph.h_factor, ge_le(1.0, 2.5), "");
  sph.alpha = number(t, "alpha", sph.alpha, ge(0), "");
  sph.beta = number(t, "beta", sph.beta, ge(0), "");
  sph.artificial_stress = number(t, "artificial_stress", sph.artificial_stress, ge_le(0, 1), "");
  sph.artificial_stress_n = number(t, "artificial_stress_n", sph.artificial_stress_n, ge_le(1, 10), "");
  sph.regularise_every =
      static_cast<int>(integer(t, "regularise_every", sph.regularise_every, 0, INT_MAX));
  sph.kernel_correction = boolean(t, "kernel_correction", sph.kernel_correction);
  sph.neighbour_skin = number(t, "neighbour_skin", sph.neighbour_skin, ge_le(0, 1), "");
  sph.axis_radius_factor = number(t, "axis_radius_factor", sph.axis_radius_factor, gt_le(0, 1), "");
}

// A material: its name, its model (a registered one, models/ModelList.hpp), then exactly the
// keys that model declares (core/MaterialModel.hpp), each with its declared range.
MaterialSpec read_material(const Reporter& rep, const toml::table& tbl, const std::string& prefix,
                           const std::vector<MaterialSpec>& earlier) {
  std::vector<std::string> every_key = {"name", "model", "unit_weight"};
  auto add_key = [](std::vector<std::string>& list, const std::string& k) {
    if (std::find(list.begin(), list.end(), k) == list.end()) list.push_back(k);
  };
  std::vector<std::string> model_names;
  for (const auto& d : material_models()) {
    model_names.push_back(d.name);
    for (const ModelKey* k : keys_of(d)) add_key(every_key, k->key);
  }
  const Table m(rep, tbl, prefix, every_key);

  MaterialSpec mat;
  mat.name = required_string(m, "name", "a non-empty string, unique among the materials");
  if (mat.name.empty())
    m.rep().out_of_range(m.path("name"), *m.find("name"), "a non-empty string, unique among the materials");
  for (std::size_t j = 0; j < earlier.size(); ++j)
    if (earlier[j].name == mat.name)
      m.rep().bad(m.path("name"), *m.find("name"), "is already used by materials[" + std::to_string(j) + "]",
                  "a name unique among the materials");
  mat.model = choice(m, "model", model_names, "model", std::nullopt);
  const ModelDescription& d = *find_material_model(mat.model);
  const std::vector<const ModelKey*> keys = keys_of(d);

  // A key of another model: say which model this one is.
  std::vector<std::string> own = {"name", "model", "unit_weight"};
  for (const ModelKey* k : keys) add_key(own, k->key);
  for (const auto& [k, v] : tbl)
    if (std::find(own.begin(), own.end(), std::string(k.str())) == own.end())
      m.rep().bad(m.path(k.str()), v, "is not used by model " + quote(mat.model), join(own, ", "));

  const auto density = opt_number(m, "density", gt(0), "kg/m3");
  const auto unit_weight = opt_number(m, "unit_weight", gt(0), "N/m3");
  const std::string one_of =
      "exactly one of density (kg/m3 > 0) or unit_weight (N/m3 > 0, converted with g = 9.81)";
  if (density && unit_weight)
    m.rep().bad(m.path("unit_weight"), *m.find("unit_weight"),
                "conflicts with " + m.path("density") + " = " + repr(*m.find("density")), one_of);
  if (!density && !unit_weight) m.rep().missing(m.path("density"), one_of);
  mat.density = density ? *density : *unit_weight / kUnitWeightGravity;

  for (const ModelKey* k : keys) {
    if (k->key == "density") continue;
    key_value(mat, *k) = k->fallback ? number(m, k->key, *k->fallback, k->range, k->unit)
                                     : required_number(m, k->key, k->range, k->unit);
  }
  auto blame = [&](const RuleBreak& b) {
    if (const auto* n = m.find(b.key)) m.rep().bad(m.path(b.key), *n, b.problem, b.allowed);
    m.rep().missing(m.path(b.key), b.allowed);
  };
  if (d.rule)
    if (const auto broken = d.rule(mat)) blame(*broken);
  if (d.effects && mat.crush_pressure > 0 && mat.air_voids <= 0)
    blame({"crush_pressure", "needs air_voids > 0", "air_voids in (0, 1): the largest compaction strain"});
  if (mat.separation_density > 0 && mat.separation_density >= mat.density)
    blame({"separation_density", "is not below the material's density " + fmt_float(mat.density) + " kg/m3",
           "0 (never) or a density below it: the loosest packing, grain density / (1 + e_max)"});
  return mat;
}

BlockSpec read_block(const Table& b, const std::vector<MaterialSpec>& materials) {
  BlockSpec blk;
  std::vector<std::string> names;
  for (const auto& m : materials) names.push_back(quote(m.name));
  blk.material = required_string(b, "material", "the name of a material: " + join(names, ", "));
  bool found = false;
  for (const auto& m : materials) found = found || m.name == blk.material;
  if (!found) b.rep().bad(b.path("material"), *b.find("material"), "is not a known material", join(names, ", "));

  // Coordinates within 10 km of the origin: a model of a lab or a site, and no extent whose
  // particle or element count overflows before validation can count it.
  constexpr double far = 1e4;
  const std::string r_shape = "[r_min, r_max] with 0 <= r_min < r_max <= 1e4 (m)";
  const auto r = opt_pair(b, "r", r_shape);
  if (!r) b.rep().missing(b.path("r"), r_shape);
  if (!((*r)[0] >= 0 && (*r)[0] < (*r)[1] && (*r)[1] <= far)) b.rep().out_of_range(b.path("r"), *b.find("r"), r_shape);

  const std::string z_shape = "[z_min, z_max] with -1e4 <= z_min < z_max <= 1e4 (m)";
  const auto z = opt_pair(b, "z", z_shape);
  if (!z) b.rep().missing(b.path("z"), z_shape);
  if (!((*z)[0] < (*z)[1] && (*z)[0] >= -far && (*z)[1] <= far)) b.rep().out_of_range(b.path("z"), *b.find("z"), z_shape);

  const auto v = opt_pair(b, "velocity", "[v_r, v_z] (m/s)");
  blk.r_min = (*r)[0];
  blk.r_max = (*r)[1];
  blk.z_min = (*z)[0];
  blk.z_max = (*z)[1];
  if (v) {
    blk.velocity_r = (*v)[0];
    blk.velocity_z = (*v)[1];
  }
  return blk;
}

WallSpec read_wall(const Table& bnd, const char* key, const char* pos_key, const Range& pos_range) {
  WallSpec w;
  const toml::table* tt = sub_table(bnd, key);
  if (!tt) return w;
  const Table t(bnd.rep(), *tt, bnd.path(key), {"type", pos_key, "spring_distance"});
  const std::string type = choice(t, "type", {"fixed", "roller", "non-reflecting", "none"}, "wall type", std::nullopt);
  w.type = type == "fixed"            ? WallType::Fixed
           : type == "roller"         ? WallType::Roller
           : type == "non-reflecting" ? WallType::NonReflecting
                                      : WallType::None;
  if (w.type == WallType::None)
    w.position = number(t, pos_key, 0, pos_range, "m");
  else
    if (!t.find(pos_key))
      t.rep().missing(t.path(pos_key), pos_range.text(pos_key, "m") + ", the wall position, for type " + quote(type));
    else
      w.position = required_number(t, pos_key, pos_range, "m");
  if (const toml::node* sd = t.find("spring_distance")) {
    if (w.type != WallType::NonReflecting)
      t.rep().bad(t.path("spring_distance"), *sd, "is set for a wall of type " + quote(type),
                  "spring_distance only with type = \"non-reflecting\"");
    w.spring_distance = required_number(t, "spring_distance", ge(0), "m");
  }
  return w;
}

void read_boundaries(const Table& top, Config& cfg) {
  const toml::table* tt = sub_table(top, "boundaries");
  if (!tt) return;
  const Table t(top.rep(), *tt, "boundaries", {"bottom", "top", "outer"});
  cfg.bottom = read_wall(t, "bottom", "z", any());
  cfg.top = read_wall(t, "top", "z", any());
  cfg.outer = read_wall(t, "outer", "r", gt(0));
  if (cfg.bottom.type != WallType::None && cfg.top.type != WallType::None &&
      !(cfg.top.position > cfg.bottom.position))
    t.rep().out_of_range("boundaries.top.z", *tt->get_as<toml::table>("top")->get("z"),
                         "top.z > bottom.z (= " + fmt_num(cfg.bottom.position) + ") (m)");
}

void read_contact(const Table& top, ContactSpec& c) {
  const toml::table* tt = sub_table(top, "contact");
  if (!tt) return;
  const Table t(top.rep(), *tt, "contact",
                {"static_friction", "dynamic_friction", "decay", "penalty_scale", "damping_ratio"});
  c.static_friction = number(t, "static_friction", c.static_friction, ge(0), "");
  c.dynamic_friction = number(t, "dynamic_friction", c.dynamic_friction, ge(0), "");
  if (c.dynamic_friction > c.static_friction)
    t.rep().out_of_range(t.path("dynamic_friction"), *t.find("dynamic_friction"),
                         "0 <= dynamic_friction <= static_friction (= " + fmt_num(c.static_friction) + ")");
  c.decay = number(t, "decay", c.decay, ge(0), "s/m");
  c.penalty_scale = number(t, "penalty_scale", c.penalty_scale, gt_le(0, 4), "");
  c.damping_ratio = number(t, "damping_ratio", c.damping_ratio, ge_le(0, 1), "");
}

void read_pounder(const Table& top, PounderSpec& p) {
  const toml::table* tt = sub_table(top, "pounder");
  if (!tt) top.rep().missing("pounder", "a [pounder] section (mass, base_diameter, max_diameter, height) with [schedule]");
  const Table t(top.rep(), *tt, "pounder", {"mass", "base_diameter", "max_diameter", "height", "profile_segments"});
  p.mass = required_number(t, "mass", gt(0), "kg");
  p.base_diameter = required_number(t, "base_diameter", gt(0), "m");
  p.max_diameter = required_number(t, "max_diameter", gt(0), "m");
  if (p.max_diameter < p.base_diameter)
    t.rep().out_of_range(t.path("max_diameter"), *t.find("max_diameter"),
                         "max_diameter >= base_diameter (= " + fmt_num(p.base_diameter) + ") (m)");
  p.height = required_number(t, "height", gt(0), "m");
  p.profile_segments = static_cast<int>(integer(t, "profile_segments", p.profile_segments, 1, 40));
}

// [fem]: elements outside an SPH zone. The zone and the blocks must fall on the particle
// grid (multiples of the spacing from each block's corner) so that the particles fill the
// zone exactly; the elements follow every block and zone edge.
void read_fem(const Table& top, Config& cfg) {
  FemSpec& f = cfg.fem;
  const toml::table* tt = sub_table(top, "fem");
  if (!tt) return;
  const Table t(top.rep(), *tt, "fem", {"enabled", "element_size", "grading", "sph_zone", "hourglass", "hourglass_coefficient", "cfl", "subcycle"});
  f.enabled = boolean(t, "enabled", true);
  const double dp = cfg.sph.spacing;
  // Measured limits (docs/coupling.md): elements finer than the particles are not tied; 2 x 2
  // tie particles per element ran stable, 4 x 4 (the paper's 2.5 mm on 10 mm) went unstable.
  // The tie limits only bind a model that has elements: with [fem] switched off the key is
  // kept for a later `--set fem.enabled=true` and need only be a length, so that
  // `--set sph.spacing=...` on an all-particle deck is not refused over unused elements.
  if (f.enabled)
    f.element_size = number(t, "element_size", dp, ge_le(dp, 2 * dp),
                            "m (sph.spacing <= element_size <= 2 sph.spacing: finer elements are not tied, "
                            "coarser ones were unstable at the tie)");
  else
    f.element_size = number(t, "element_size", dp, gt(0), "m");
  f.grading = number(t, "grading", f.grading, ge_le(1, 1.5), "(element edge growth per element away from the SPH zone)");
  f.hourglass = choice(t, "hourglass", {"viscous", "stiffness"}, "hourglass control", f.hourglass);
  f.hourglass_coefficient = number(t, "hourglass_coefficient", f.hourglass_coefficient, ge_le(0, 1), "");
  f.cfl = number(t, "cfl", f.cfl, gt_le(0, 1), "");
  f.subcycle = boolean(t, "subcycle", f.subcycle);
  const std::string zone_shape = "an inline table { r = [r_min, r_max], z = [z_min, z_max] } (m) inside the blocks";
  const toml::table* zt = sub_table(t, "sph_zone");
  if (!zt) {
    t.rep().missing(t.path("sph_zone"), zone_shape);
  }
  const Table z(top.rep(), *zt, t.path("sph_zone"), {"r", "z"});
  const auto r = opt_pair(z, "r", "[r_min, r_max] with 0 <= r_min < r_max (m)");
  const auto zz = opt_pair(z, "z", "[z_min, z_max] with z_min < z_max (m)");
  if (!r) z.rep().missing(z.path("r"), "[r_min, r_max] with 0 <= r_min < r_max (m)");
  if (!zz) z.rep().missing(z.path("z"), "[z_min, z_max] with z_min < z_max (m)");
  if (!((*r)[0] >= 0 && (*r)[0] < (*r)[1])) z.rep().out_of_range(z.path("r"), *z.find("r"), "0 <= r_min < r_max (m)");
  if (!((*zz)[0] < (*zz)[1])) z.rep().out_of_range(z.path("z"), *z.find("z"), "z_min < z_max (m)");
  f.zone_r_min = (*r)[0]; f.zone_r_max = (*r)[1];
  f.zone_z_min = (*zz)[0]; f.zone_z_max = (*zz)[1];
  if (!f.enabled) return;
  // Mass scaling acts on the particles' inertia (kernels/Integrate.hpp Kick); the elements'
  // nodal masses do not carry it.
  for (std::size_t i = 0; i < cfg.materials.size(); ++i)
    if (cfg.materials[i].mass_scaling != 1.0)
      t.rep().bad("materials[" + std::to_string(i) + "].mass_scaling", fmt_num(cfg.materials[i].mass_scaling),
                  "with [fem] enabled = true (material '" + cfg.materials[i].name + "')",
                  "1 (no mass scaling) with [fem] enabled, or [fem] enabled = false");
  if (f.zone_r_min != 0.0)
    z.rep().out_of_range(z.path("r"), *z.find("r"), "r = [0, r_max]: the zone is around the axis (a ring-shaped zone is not supported)");
  // the zone lies on the particle grid of the blocks it cuts
  auto on_grid = [&](double v, double origin) {
    const double k = (v - origin) / dp;
    return std::fabs(k - std::round(k)) < 1e-6;
  };
  for (const auto& b : cfg.blocks) {
    const bool cuts = f.zone_r_max > b.r_min && f.zone_r_min < b.r_max && f.zone_z_max > b.z_min && f.zone_z_min < b.z_max;
    if (!cuts) continue;
    const std::string grid = "zone edges at whole particle spacings (" + fmt_num(dp) + " m) from the corner of each block it cuts";
    if (!on_grid(f.zone_r_max, b.r_min)) z.rep().out_of_range(z.path("r"), *z.find("r"), grid);
    if (!on_grid(f.zone_z_min, b.z_min) || !on_grid(f.zone_z_max, b.z_min)) z.rep().out_of_range(z.path("z"), *z.find("z"), grid);
  }
}

void read_backfill(const Table& top, Config& cfg) {
  BackfillSpec& b = cfg.backfill;
  const toml::table* tt = sub_table(top, "backfill");
  if (!tt) return;
  const Table t(top.rep(), *tt, "backfill", {"material", "mode", "mass", "radius"});
  std::vector<std::string> names;
  for (const auto& m : cfg.materials) names.push_back(quote(m.name));
  b.material = required_string(t, "material", "the name of a material: " + join(names, ", "));
  bool found = false;
  for (const auto& m : cfg.materials) found = found || m.name == b.material;
  if (!found) t.rep().bad(t.path("material"), *t.find("material"), "is not a known material", join(names, ", "));
  b.mode = choice(t, "mode", {"fill", "surface", "mass"}, "backfill mode", b.mode);
  b.mass = number(t, "mass", b.mass, gt(0), "kg");
  b.radius = number(t, "radius", b.radius, ge(0), "m");
}

void read_schedule(const Table& top, Config& cfg) {
  ScheduleSpec& s = cfg.schedule;
  const toml::table* tt = sub_table(top, "schedule");
  if (!tt) return;
  const Table t(top.rep(), *tt, "schedule",
                {"drop_heights", "backfill_after", "drop_height_from", "ground_level", "relax_time", "damping",
                 "rest_speed", "rest_force_tolerance", "rest_hold", "rest_time", "max_impact_time", "extract_time", "settle_time",
                 "tracer_interval", "flight", "flight_relax_time"});
  s.enabled = true;
  s.drop_heights = number_array(t, "drop_heights", gt(0), "m");
  s.backfill_after = increasing_int_array(t, "backfill_after", 1, static_cast<long long>(s.drop_heights.size()));
  if (!s.backfill_after.empty() && cfg.backfill.material.empty())
    t.rep().bad(t.path("backfill_after"), *t.find("backfill_after"), "needs a [backfill] section",
                "a [backfill] section with material = \"...\", or no backfill_after");
  s.drop_height_from = choice(t, "drop_height_from", {"ground", "surface"}, "reference", s.drop_height_from);
  s.ground_level = number(t, "ground_level", s.ground_level, any(), "m");
  s.relax_time = number(t, "relax_time", s.relax_time, ge(0), "s");
  s.damping = number(t, "damping", s.damping, ge(0), "1/s");
  s.rest_speed = number(t, "rest_speed", s.rest_speed, gt(0), "m/s");
  s.rest_force_tolerance = number(t, "rest_force_tolerance", s.rest_force_tolerance, gt(0), "-");
  s.rest_hold = number(t, "rest_hold", s.rest_hold, ge(0), "s");
  s.rest_time = number(t, "rest_time", s.rest_time, ge(0), "s");
  s.max_impact_time = number(t, "max_impact_time", s.max_impact_time, gt(0), "s");
  s.extract_time = number(t, "extract_time", s.extract_time, ge(0), "s");
  s.settle_time = number(t, "settle_time", s.settle_time, ge(0), "s");
  s.tracer_interval = number(t, "tracer_interval", s.tracer_interval, gt(0), "s");
  s.flight = choice(t, "flight", {"followed", "ballistic"}, "flight mode", s.flight);
  s.flight_relax_time = number(t, "flight_relax_time", s.flight_relax_time, gt(0), "s");
}

void read_tracers(const Table& top, Config& cfg) {
  const toml::node* n = top.find("tracers");
  if (!n) return;
  const auto list = table_array(top, "tracers");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Table t(top.rep(), *list[i], "tracers[" + std::to_string(i) + "]", {"name", "r", "z"});
    TracerSpec tr;
    tr.name = required_string(t, "name", "a non-empty name (a CSV column)");
    if (tr.name.empty() || tr.name.find_first_of(",\"\n") != std::string::npos)
      t.rep().out_of_range(t.path("name"), *t.find("name"), "a non-empty name without commas, quotes or newlines");
    tr.r = required_number(t, "r", ge(0), "m");
    tr.z = required_number(t, "z", any(), "m");
    cfg.tracers.push_back(tr);
  }
}

// ---------------------------------------------------------------- a model that can run

// "1.5e+11", "4.3e+09": three significant digits, for counts in messages.
std::string fmt_num_short(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}
// "165 TB", "12.3 GB", "640 MB".
std::string fmt_bytes(double b) {
  const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
  int k = 0;
  while (b >= 1000 && k < 6) { b /= 1000; ++k; }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g %s", b, units[k]);
  return buf;
}

// What validation of single keys cannot see: every block at least half a spacing thick
// along r and z (one particle), a particle count that fits (core/ParticleGrid.hpp), and a
// finite, positive stable step and step count (the CFL step on the fastest P-wave speed,
// dt = cfl h / c_p, as kernels/Integrate.hpp StableStep takes it at rest).
void check_runnable(const Reporter& rep, const Config& cfg, const std::vector<const toml::table*>& block_tables,
                    const std::vector<const toml::table*>& material_tables) {
  const double dp = cfg.sph.spacing;
  const std::string spacing = "sph.spacing = " + fmt_num(dp) + " m";
  double asked = 0;
  for (std::size_t i = 0; i < cfg.blocks.size(); ++i) {
    const BlockSpec& b = cfg.blocks[i];
    const std::string p = "blocks[" + std::to_string(i) + "]";
    const double nr = std::round((b.r_max - b.r_min) / dp), nz = std::round((b.z_max - b.z_min) / dp);
    if (!(nr >= 1))
      rep.bad(p + ".r", *block_tables[i]->get("r"), "is thinner than one particle spacing (" + spacing + ")",
              "r_max - r_min >= spacing / 2");
    if (!(nz >= 1))
      rep.bad(p + ".z", *block_tables[i]->get("z"), "is thinner than one particle spacing (" + spacing + ")",
              "z_max - z_min >= spacing / 2");
  }
  for (const BlockParticles& c : particle_grid(cfg)) asked += c.count();
  if (!(asked <= kMaxParticles))
    rep.bad("sph.spacing", fmt_num(dp),
            "makes the blocks ask for " + fmt_num_short(asked) + " particles (about " +
                fmt_bytes(asked * kBytesPerParticle) + " of memory)",
            "a spacing giving at most " + fmt_num_short(kMaxParticles) + " particles");

  double c_max = 0;
  for (std::size_t i = 0; i < cfg.materials.size(); ++i) {
    const MaterialSpec& m = cfg.materials[i];
    const std::string p = "materials[" + std::to_string(i) + "]";
    const double K = bulk_from_shear(m.shear_modulus, m.poisson_ratio);
    const double M = K + 4.0 / 3.0 * m.shear_modulus;
    const double c = std::sqrt(M / m.density);
    if (std::isfinite(c) && c > 0) {
      c_max = std::max(c_max, c);
      continue;
    }
    const toml::table& t = *material_tables[i];
    const std::string why = "gives a P-wave speed sqrt((K + 4G/3) / rho) of " + fmt_num(c) + " m/s";
    if (!std::isfinite(M)) rep.bad(p + ".G", *t.get("G"), why, "G (Pa) with a finite P-wave modulus K + 4G/3");
    const char* key = t.get("density") ? "density" : "unit_weight";
    rep.bad(p + "." + key, *t.get(key), why + " (density " + fmt_num(m.density) + " kg/m3)",
            "a density giving a finite wave speed");
  }
  if (cfg.materials.empty()) return;
  const double dt = cfg.run.cfl * cfg.sph.h_factor * dp / c_max;
  if (!(std::isfinite(dt) && dt > 0))
    rep.bad("run.cfl", fmt_num(cfg.run.cfl), "with " + spacing + " gives a stable step of " + fmt_num(dt) + " s",
            "a cfl and spacing giving a positive time step");
  const double steps = cfg.run.end_time / dt;
  if (!(steps < 1e15))
    rep.bad("run.end_time", fmt_num(cfg.run.end_time),
            "asks for " + fmt_num_short(steps) + " steps of the stable step " + fmt_num(dt) + " s (run.cfl = " +
                fmt_num(cfg.run.cfl) + ")",
            "at most 1e15 steps");
}

Config build(const toml::table& root, const std::string& label) {
  const Reporter rep(label);
  Config cfg;
  cfg.source_file = label;
  const Table top(rep, root, "", {"run", "sph", "gravity", "damping", "gravity_ramp", "initial_stress", "materials",
                                         "blocks", "boundaries", "contact", "pounder", "backfill", "schedule",
                                         "tracers", "fem"});
  cfg.gravity = number(top, "gravity", cfg.gravity, ge(0), "m/s2");
  cfg.damping = number(top, "damping", cfg.damping, ge(0), "1/s");
  cfg.gravity_ramp = number(top, "gravity_ramp", cfg.gravity_ramp, ge(0), "s");
  cfg.initial_stress = choice(top, "initial_stress", {"zero", "geostatic"}, "initial stress", cfg.initial_stress);
  read_run(top, cfg.run);
  read_sph(top, cfg.sph);

  const auto mats = table_array(top, "materials");
  for (std::size_t i = 0; i < mats.size(); ++i)
    cfg.materials.push_back(read_material(rep, *mats[i], "materials[" + std::to_string(i) + "]", cfg.materials));
  const auto blocks = table_array(top, "blocks");
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Table b(rep, *blocks[i], "blocks[" + std::to_string(i) + "]", {"material", "r", "z", "velocity"});
    cfg.blocks.push_back(read_block(b, cfg.materials));
  }
  read_boundaries(top, cfg);
  read_fem(top, cfg);
  read_contact(top, cfg.contact);
  read_backfill(top, cfg);
  read_schedule(top, cfg);
  if (cfg.schedule.enabled) read_pounder(top, cfg.pounder);
  else if (const auto* p = top.find("pounder"))
    rep.bad("pounder", *p, "is only used with a [schedule]", "a [schedule] section, or no [pounder]");
  read_tracers(top, cfg);
  check_runnable(rep, cfg, blocks, mats);
  return cfg;
}

// ---------------------------------------------------------------- writing

const char* wall_name(WallType t) {
  switch (t) {
    case WallType::Fixed: return "fixed";
    case WallType::Roller: return "roller";
    case WallType::NonReflecting: return "non-reflecting";
    default: return "none";
  }
}

std::string wall_text(const WallSpec& w, const char* pos_key) {
  std::string s = std::string("{ type = ") + quote(wall_name(w.type));
  if (w.type != WallType::None || w.position != 0) s += std::string(", ") + pos_key + " = " + fmt_float(w.position);
  if (w.type == WallType::NonReflecting && w.spring_distance >= 0)
    s += ", spring_distance = " + fmt_float(w.spring_distance);
  return s + " }";
}

}  // namespace

// ---------------------------------------------------------------- public API

namespace {

// TOML text -> table; a syntax error throws DeckError from `on_error(line, column, why)`
// (with or without toml++'s exceptions).
template <class OnError>
toml::table parse_toml(const std::string& text, const std::string& label, const OnError& on_error) {
#if TOML_EXCEPTIONS
  try {
    return toml::parse(text, label);
  } catch (const toml::parse_error& e) {
    on_error(e.source().begin.line, e.source().begin.column, std::string(e.description()));
  }
  return {};
#else
  toml::parse_result res = toml::parse(text, label);
  if (!res) on_error(res.error().source().begin.line, res.error().source().begin.column,
                     std::string(res.error().description()));
  return std::move(res).table();
#endif
}

// One --set KEY=VALUE applied to the parsed deck (see Deck.hpp). The value is parsed as
// the right-hand side of a TOML key, so the deck's own types apply; the validator then
// checks it where it lands. KEY= with nothing after '=' removes the key (a model switch
// by hand: the old model's keys must go, e.g. clay.Su= when clay becomes Cam-Clay).
void apply_override(toml::table& root, const std::string& setting, const std::string& deck) {
  const auto fail = [&](const std::string& why) {
    throw DeckError(printable(deck) + ": --set '" + printable(setting) + "': " + why);
  };
  const auto eq = setting.find('=');
  if (eq == std::string::npos || eq == 0)
    fail("expected KEY=VALUE, e.g. sph.spacing=0.005, fem.enabled=true or clay.Su=12000");
  const std::string key = setting.substr(0, eq), text = setting.substr(eq + 1);
  std::vector<std::string> path;
  for (std::size_t from = 0;;) {
    const auto dot = key.find('.', from);
    path.push_back(key.substr(from, dot == std::string::npos ? std::string::npos : dot - from));
    if (path.back().empty()) fail("the key '" + printable(key) + "' has an empty part");
    if (dot == std::string::npos) break;
    from = dot + 1;
  }
  const bool remove = text.empty();
  const std::string value_error =
      "the value '" + printable(text) + "' is not a TOML value; allowed: a number (0.005), true or false, "
      "a quoted string (\"fill\") or an array ([0.3, 0.5]), or nothing to remove the key";
  const toml::table value_doc =
      remove ? toml::table{} : parse_toml("value = " + text, "--set", [&](auto, auto, const auto&) { fail(value_error); });
  if (!remove && value_doc.size() != 1) fail(value_error);  // e.g. "1\nother = 2"
  const toml::node* value = value_doc.get("value");  // a non-finite number is the validator's to refuse

  // <material name>.<key>: the [[materials]] entry of that name.
  toml::table* target = &root;
  std::size_t first = 0;
  if (path.size() == 2)
    if (toml::array* mats = root["materials"].as_array())
      for (toml::node& m : *mats)
        if (toml::table* t = m.as_table(); t && t->get("name") && t->get("name")->value<std::string>() == path[0]) {
          target = t;
          first = 1;
        }
  const auto absent = [&] { fail("the deck has no '" + printable(key) + "' to remove"); };
  for (std::size_t i = first; i + 1 < path.size(); ++i) {
    toml::node* next = target->get(path[i]);
    if (!next) {
      if (remove) absent();
      target->insert(path[i], toml::table{});
      next = target->get(path[i]);
    }
    if (!next->is_table())
      fail("'" + printable(path[i]) + "' is a " + type_name(*next) + " in the deck, not a table that holds '" +
           printable(path[i + 1]) + "'");
    target = next->as_table();
  }
  if (remove) {
    if (!target->contains(path.back())) absent();
    target->erase(path.back());
    return;
  }
  target->insert_or_assign(path.back(), *value);
}

}  // namespace

namespace {
std::string take_materials_from(toml::table& root, const std::string& file_label);
}
static Config parse_with(toml::table& root, const std::string& file_label, const std::vector<std::string>& overrides);

Config parse_deck(const std::string& toml_text, const std::string& file_label,
                  const std::vector<std::string>& overrides) {
  toml::table root = parse_toml(toml_text, file_label, [&](auto line, auto column, const std::string& why) {
    throw DeckError(printable(file_label) + ": TOML syntax error at line " + std::to_string(line) + ", column " +
                    std::to_string(column) + ": " + why);
  });
  const std::string from = take_materials_from(root, file_label);
  if (!from.empty()) {  // a material's error names the file it is written in
    try {
      return parse_with(root, file_label, overrides);
    } catch (const DeckError& e) {
      const std::string what = e.what();
      if (what.find("materials") == std::string::npos) throw;
      throw DeckError(what + " (the materials are those of " + printable(from) + ")");
    }
  }
  return parse_with(root, file_label, overrides);
}

namespace {
// The deck's [[materials]] taken from another deck: `materials_from = "PATH"` (relative to the
// deck's folder), so that decks share one set of materials (the CI scenario takes the lab
// deck's). Returns the path read, or "" when the key is absent; the key is removed from root.
std::string take_materials_from(toml::table& root, const std::string& file_label) {
  const toml::node* node = root.get("materials_from");
  if (!node) return "";
  const auto* path = node->as_string();
  if (!path)
    throw DeckError(printable(file_label) + ": materials_from is not a string; allowed: the path of a deck whose "
                    "[[materials]] this deck takes");
  if (root.contains("materials"))
    throw DeckError(printable(file_label) + ": materials_from = " + quote(path->get()) +
                    " and [[materials]] both given; allowed: one of them");
  namespace fs = std::filesystem;
  fs::path from(path->get());
  if (from.is_relative()) from = fs::path(file_label).parent_path() / from;
  const std::string from_s = from.lexically_normal().string();
  try {
    require_regular_file(from_s, "deck file");
  } catch (const DeckError& e) {
    throw DeckError(printable(file_label) + ": materials_from = " + quote(path->get()) + ": " + e.what() +
                    "; allowed: the path of a deck with [[materials]], relative to this deck's folder");
  }
  std::ifstream in(from_s, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  toml::table other = parse_toml(text.str(), from_s, [&](auto line, auto column, const std::string& why) {
    throw DeckError(printable(from_s) + ": TOML syntax error at line " + std::to_string(line) + ", column " +
                    std::to_string(column) + ": " + why);
  });
  const toml::node* mats = other.get("materials");
  if (!mats || !mats->is_array())
    throw DeckError(printable(file_label) + ": materials_from = " + quote(path->get()) +
                    ": that deck has no [[materials]]; allowed: a deck with [[materials]]");
  root.insert("materials", *mats->as_array());
  root.erase("materials_from");
  return from_s;
}
}  // namespace

static Config parse_with(toml::table& root, const std::string& file_label, const std::vector<std::string>& overrides) {
  if (overrides.empty()) return build(root, file_label);
  for (const auto& o : overrides) apply_override(root, o, file_label);
  try {
    return build(root, file_label);
  } catch (const DeckError& e) {
    std::string sets;
    for (const auto& o : overrides) sets += (sets.empty() ? "" : ", ") + printable(o);
    throw DeckError(std::string(e.what()) + " (with --set " + sets + ")");
  }
}

void require_regular_file(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw DeckError(printable(path) + ": the " + what + " does not exist");
  if (fs::is_directory(st)) throw DeckError(printable(path) + ": is a directory, not a " + what);
  if (!fs::is_regular_file(st))
    throw DeckError(printable(path) + ": is not a regular file (a FIFO, device or socket is not read); allowed: a " + what);
}

Config load_deck(const std::string& path, const std::vector<std::string>& overrides) {
  require_regular_file(path, "deck file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DeckError(printable(path) + ": cannot open the deck file (" + std::strerror(errno) + ")");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw DeckError(printable(path) + ": cannot read the deck file");
  return parse_deck(text.str(), path, overrides);
}

std::string to_toml(const Config& c) {
  std::ostringstream o;
  o << "# Tamp input deck";
  if (!c.source_file.empty()) o << " (effective values of " << quote(c.source_file) << ")";
  o << "\n# SI units; gravity acts in -z; r >= 0 is the radial coordinate.\n\n";
  o << "gravity = " << fmt_float(c.gravity) << "  # m/s2\n";
  o << "damping = " << fmt_float(c.damping) << "  # 1/s\n";
  o << "gravity_ramp = " << fmt_float(c.gravity_ramp) << "  # s\n";
  o << "initial_stress = " << quote(c.initial_stress) << "\n\n";

  o << "[run]\n";
  o << "name = " << quote(c.run.name) << "\n";
  o << "end_time = " << fmt_float(c.run.end_time) << "  # s\n";
  o << "output_interval = " << fmt_float(c.run.output_interval) << "  # s, 0 = final state only\n";
  o << "cfl = " << fmt_float(c.run.cfl) << "\n";
  o << "progress_interval = " << fmt_float(c.run.progress_interval) << "  # s of wall time\n";
  o << "max_steps = " << c.run.max_steps << "  # 0 = unlimited\n\n";

  o << "[sph]\n";
  o << "spacing = " << fmt_float(c.sph.spacing) << "  # m\n";
  o << "h_factor = " << fmt_float(c.sph.h_factor) << "\n";
  o << "alpha = " << fmt_float(c.sph.alpha) << "\n";
  o << "beta = " << fmt_float(c.sph.beta) << "\n";
  o << "artificial_stress = " << fmt_float(c.sph.artificial_stress) << "\n";
  o << "artificial_stress_n = " << fmt_float(c.sph.artificial_stress_n) << "\n";
  o << "regularise_every = " << c.sph.regularise_every << "\n";
  o << "kernel_correction = " << (c.sph.kernel_correction ? "true" : "false") << "\n";
  o << "neighbour_skin = " << fmt_float(c.sph.neighbour_skin) << "\n";
  o << "axis_radius_factor = " << fmt_float(c.sph.axis_radius_factor) << "\n\n";

  o << "[boundaries]\n";
  o << "bottom = " << wall_text(c.bottom, "z") << "\n";
  o << "top = " << wall_text(c.top, "z") << "\n";
  o << "outer = " << wall_text(c.outer, "r") << "\n";

  if (c.fem.enabled || c.fem.zone_r_max > 0) {
    o << "\n[fem]\n";
    o << "enabled = " << (c.fem.enabled ? "true" : "false") << "\n";
    o << "element_size = " << fmt_float(c.fem.element_size) << "  # m\n";
    o << "grading = " << fmt_float(c.fem.grading) << "\n";
    o << "sph_zone = { r = [" << fmt_float(c.fem.zone_r_min) << ", " << fmt_float(c.fem.zone_r_max) << "], z = ["
      << fmt_float(c.fem.zone_z_min) << ", " << fmt_float(c.fem.zone_z_max) << "] }  # m\n";
    o << "hourglass = " << quote(c.fem.hourglass) << "\n";
    o << "hourglass_coefficient = " << fmt_float(c.fem.hourglass_coefficient) << "\n";
    o << "cfl = " << fmt_float(c.fem.cfl) << "\n";
    o << "subcycle = " << (c.fem.subcycle ? "true" : "false") << "\n";
  }

  o << "\n[contact]\n";
  o << "static_friction = " << fmt_float(c.contact.static_friction) << "\n";
  o << "dynamic_friction = " << fmt_float(c.contact.dynamic_friction) << "\n";
  o << "decay = " << fmt_float(c.contact.decay) << "  # s/m\n";
  o << "penalty_scale = " << fmt_float(c.contact.penalty_scale) << "\n";
  o << "damping_ratio = " << fmt_float(c.contact.damping_ratio) << "\n";
  if (!c.backfill.material.empty()) {
    o << "\n[backfill]\n";
    o << "material = " << quote(c.backfill.material) << "\n";
    o << "mode = " << quote(c.backfill.mode) << "\n";
    o << "mass = " << fmt_float(c.backfill.mass) << "  # kg\n";
    o << "radius = " << fmt_float(c.backfill.radius) << "  # m, 0 = automatic\n";
  }
  if (c.schedule.enabled) {
    const ScheduleSpec& s = c.schedule;
    o << "\n[pounder]\n";
    o << "mass = " << fmt_float(c.pounder.mass) << "  # kg\n";
    o << "base_diameter = " << fmt_float(c.pounder.base_diameter) << "  # m\n";
    o << "max_diameter = " << fmt_float(c.pounder.max_diameter) << "  # m\n";
    o << "height = " << fmt_float(c.pounder.height) << "  # m\n";
    o << "profile_segments = " << c.pounder.profile_segments << "\n";
    o << "\n[schedule]\n";
    o << "drop_heights = [";
    for (size_t k = 0; k < s.drop_heights.size(); ++k) o << (k ? ", " : "") << fmt_float(s.drop_heights[k]);
    o << "]  # m\nbackfill_after = [";
    for (size_t k = 0; k < s.backfill_after.size(); ++k) o << (k ? ", " : "") << s.backfill_after[k];
    o << "]\n";
    o << "drop_height_from = " << quote(s.drop_height_from) << "\n";
    o << "ground_level = " << fmt_float(s.ground_level) << "  # m, 0 = top of the blocks\n";
    o << "relax_time = " << fmt_float(s.relax_time) << "  # s\n";
    o << "damping = " << fmt_float(s.damping) << "  # 1/s\n";
    o << "rest_speed = " << fmt_float(s.rest_speed) << "  # m/s\n";
    o << "rest_force_tolerance = " << fmt_float(s.rest_force_tolerance) << "  # -\n";
    o << "rest_hold = " << fmt_float(s.rest_hold) << "  # s\n";
    o << "rest_time = " << fmt_float(s.rest_time) << "  # s\n";
    o << "max_impact_time = " << fmt_float(s.max_impact_time) << "  # s\n";
    o << "extract_time = " << fmt_float(s.extract_time) << "  # s\n";
    o << "settle_time = " << fmt_float(s.settle_time) << "  # s\n";
    o << "tracer_interval = " << fmt_float(s.tracer_interval) << "  # s\n";
    o << "flight = " << quote(s.flight) << "\n";
    o << "flight_relax_time = " << fmt_float(s.flight_relax_time) << "  # s\n";
  }
  for (const auto& tr : c.tracers) {
    o << "\n[[tracers]]\n";
    o << "name = " << quote(tr.name) << "\n";
    o << "r = " << fmt_float(tr.r) << "  # m\n";
    o << "z = " << fmt_float(tr.z) << "  # m\n";
  }
  for (const auto& m : c.materials) {
    o << "\n[[materials]]\n";
    o << "name = " << quote(m.name) << "\n";
    o << "model = " << quote(m.model) << "\n";
    for (const ModelKey* k : keys_of(material_model(m))) {
      const double x = key_value(m, *k);
      if (omitted_at_default(*k) && x == k->fallback.value_or(0.0)) continue;  // keeps decks short
      o << k->key << " = " << fmt_float(x) << (k->unit.empty() ? "" : "  # " + k->unit) << "\n";
    }
  }
  for (const auto& b : c.blocks) {
    o << "\n[[blocks]]\n";
    o << "material = " << quote(b.material) << "\n";
    o << "r = [" << fmt_float(b.r_min) << ", " << fmt_float(b.r_max) << "]  # m\n";
    o << "z = [" << fmt_float(b.z_min) << ", " << fmt_float(b.z_max) << "]  # m\n";
    o << "velocity = [" << fmt_float(b.velocity_r) << ", " << fmt_float(b.velocity_z) << "]  # m/s\n";
  }
  return o.str();
}

}  // namespace tamp
