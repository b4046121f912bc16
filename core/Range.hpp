// Allowed ranges of input numbers, with the text an error message shows ("0 <= nu < 0.5",
// "spacing > 0 (m)"). Shared by the deck reader (core/Deck.cpp) and the material model
// descriptions (core/MaterialModel.hpp), which declare each key's range once.
#pragma once
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include "core/Format.hpp"

namespace tamp {

struct Range {
  std::optional<double> lo, hi;
  bool lo_open = false, hi_open = false;

  bool contains(double x) const {
    if (!std::isfinite(x)) return false;
    if (lo && (lo_open ? !(x > *lo) : !(x >= *lo))) return false;
    if (hi && (hi_open ? !(x < *hi) : !(x <= *hi))) return false;
    return true;
  }
  // "0 <= nu < 0.5", "spacing > 0 (m)", "a finite number (m/s)".
  std::string text(std::string_view name, std::string_view unit) const {
    std::string s;
    if (lo && hi)
      s = fmt_num(*lo) + (lo_open ? " < " : " <= ") + std::string(name) + (hi_open ? " < " : " <= ") +
          fmt_num(*hi);
    else if (lo)
      s = std::string(name) + (lo_open ? " > " : " >= ") + fmt_num(*lo);
    else if (hi)
      s = std::string(name) + (hi_open ? " < " : " <= ") + fmt_num(*hi);
    else
      s = "a finite number";
    if (!unit.empty()) s += " (" + std::string(unit) + ")";
    return s;
  }
};

namespace ranges {
inline Range any() { return {}; }
inline Range gt(double a) { return {a, std::nullopt, true, false}; }
inline Range ge(double a) { return {a, std::nullopt, false, false}; }
inline Range ge_lt(double a, double b) { return {a, b, false, true}; }
inline Range ge_le(double a, double b) { return {a, b, false, false}; }
inline Range gt_le(double a, double b) { return {a, b, true, false}; }
inline Range gt_lt(double a, double b) { return {a, b, true, true}; }
}  // namespace ranges

}  // namespace tamp
