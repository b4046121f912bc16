// The run summary's one table (core/RunSummary.hpp).
#include "core/RunSummary.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/Deck.hpp"
#include "core/Format.hpp"

namespace tamp {

const std::vector<SummaryField>& run_summary_fields() {
  using S = RunSummary;
  static const std::vector<SummaryField> f{
      {"column_length_m", true, &S::column_length_m},
      {"head_diameter_m", true, &S::head_diameter_m},
      {"max_diameter_m", true, &S::max_diameter_m},
      {"base_diameter_m", true, &S::base_diameter_m},
      {"head_solid_diameter_m", false, &S::head_solid_diameter_m},
      {"max_solid_diameter_m", false, &S::max_solid_diameter_m},
      {"uplift_m", true, &S::uplift_m},
      {"aggregate_total_kg", true, &S::aggregate_total_kg},
      {"blows_completed", true, nullptr, &S::blows_completed},
      {"steps", false, nullptr, &S::steps},
      {"wall_s", false, &S::wall_s},
      {"particles", false, nullptr, &S::particles},
      {"simulated_time_s", false, &S::simulated_time_s},
      {"spacing_m", false, &S::spacing_m},
      {"heave_volume_m3", false, &S::heave_volume_m3},
      {"aggregate_volume_below_ground_m3", false, &S::aggregate_volume_below_ground_m3}};
  return f;
}

double summary_value(const RunSummary& s, const SummaryField& f) {
  return f.real ? s.*f.real : static_cast<double>(s.*f.whole);
}

std::map<std::string, double> summary_values(const RunSummary& s) {
  std::map<std::string, double> m;
  for (const auto& f : run_summary_fields()) m[f.key] = summary_value(s, f);
  return m;
}

std::string run_summary_json(const RunSummary& s) {
  nlohmann::ordered_json js;  // every number to full (round-trip) precision; NaN as null
  for (const auto& f : run_summary_fields()) {
    if (f.whole) js[f.key] = s.*f.whole;
    else js[f.key] = s.*f.real;
  }
  return js.dump(2) + "\n";
}

std::map<std::string, double> read_run_summary(const std::string& path) {
  require_regular_file(path, "run summary (JSON)");
  std::ifstream in(path);
  std::stringstream text_in;
  text_in << in.rdbuf();
  const std::string text = text_in.str();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::out_of_range& e) {
    // a number beyond double (1e999): name its key, the text before it (the library's
    // message quotes the number: "number overflow parsing '1e999'")
    const std::string what = e.what();
    std::string key = "?", number;
    const size_t a = what.find('\''), b = a == std::string::npos ? a : what.find('\'', a + 1);
    if (b != std::string::npos) number = what.substr(a + 1, b - a - 1);
    const size_t at = number.empty() ? std::string::npos : text.find(number);
    const size_t colon = at == std::string::npos ? at : text.rfind(':', at);
    if (colon != std::string::npos) {
      const size_t q1 = text.rfind('"', colon);
      const size_t q0 = q1 == std::string::npos || q1 == 0 ? std::string::npos : text.rfind('"', q1 - 1);
      if (q0 != std::string::npos) key = text.substr(q0 + 1, q1 - q0 - 1);
    }
    throw std::invalid_argument(printable(path) + ": \"" + printable(key, 60) + "\" is " + printable(number, 60) +
                                ", beyond the range of a double; allowed: a finite number or null");
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(printable(path) + " is not valid JSON (" + printable(e.what()) + ")");
  }
  if (!j.is_object() || j.empty())
    throw std::invalid_argument(printable(path) + " is not a JSON object of the run's quantities (found " +
                                std::string(j.type_name()) + ")");
  std::map<std::string, double> m;
  for (const auto& [key, value] : j.items()) {
    if (value.is_number()) m[key] = value.get<double>();
    else if (value.is_null()) m[key] = RunSummary::unknown;
    else
      throw std::invalid_argument(printable(path) + ": \"" + printable(key, 60) + "\" is " + printable(value.dump(), 60) +
                                  "; allowed: a number or null");
  }
  return m;
}

}  // namespace tamp
