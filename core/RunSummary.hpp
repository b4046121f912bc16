// The run summary (summary.json) as one typed record, its keys declared once: the drop
// sequence fills it (drivers/sequence/DropSequence.cpp), it is written and read through the
// same table, and the quantities a data file may name (core/Observations.cpp) are the table's
// observable keys. Counts are whole numbers in the file; a quantity a run could not measure is
// null (NaN here).
#pragma once
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace tamp {

struct RunSummary {
  static constexpr double unknown = std::numeric_limits<double>::quiet_NaN();
  double column_length_m = unknown;        // the column of aggregate: top of the charge to its deepest grain
  double head_diameter_m = unknown;        // the hole in the clay at the column's head
  double max_diameter_m = unknown;         // its largest diameter
  double base_diameter_m = unknown;        // its diameter at the base
  double head_solid_diameter_m = unknown;  // the aggregate's volume as a solid cylinder, at the head
  double max_solid_diameter_m = unknown;   // ... at its largest
  double uplift_m = unknown;               // largest heave of the soil surface beside the column
  double aggregate_total_kg = unknown;     // aggregate poured over the run
  long blows_completed = 0;
  long steps = 0;
  double wall_s = unknown;                 // wall time of the run, s
  long particles = 0;                      // at the end
  double simulated_time_s = unknown;
  double spacing_m = unknown;              // sph.spacing
  double heave_volume_m3 = unknown;        // soil surface above the ground outside the pounder
  double aggregate_volume_below_ground_m3 = unknown;
};

struct SummaryField {
  const char* key;
  bool observable;                          // a data file may name it
  double RunSummary::*real = nullptr;       // one of these two
  long RunSummary::*whole = nullptr;
};
// Every key of summary.json, in the file's order.
const std::vector<SummaryField>& run_summary_fields();
// The value of one field (a count as a double).
double summary_value(const RunSummary& s, const SummaryField& f);
// The record by key, for the loop's residuals.
std::map<std::string, double> summary_values(const RunSummary& s);
// summary.json's text: every number to round-trip precision, counts whole, NaN as null.
std::string run_summary_json(const RunSummary& s);
// A summary.json read back by key (numbers; NaN for null). A file that is not a JSON object
// of numbers and nulls, or holds a number beyond a double (1e999), is std::invalid_argument
// naming the file and the key; keys it does not know are kept (an older or newer run).
std::map<std::string, double> read_run_summary(const std::string& path);

}  // namespace tamp
