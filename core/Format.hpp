// Number formatting shared by the deck writer and the result files.
#pragma once
#include <charconv>
#include <cmath>
#include <string>

namespace tamp {

// Shortest text that reads back to exactly x ("0.6", "1e+09", "-1800"); "nan", "inf".
inline std::string fmt_num(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

}  // namespace tamp
