// Number formatting shared by the deck writer and the result files.
#pragma once
#include <charconv>
#include <cmath>
#include <cstdio>
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

// Text as a one-line message can show it (a file name, a value read from a file): control
// characters (a newline in a name) escaped as \xNN.
inline std::string printable(const std::string& text) {
  std::string out;
  for (const unsigned char c : text) {
    if (c >= 0x20 && c != 0x7f) {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out;
}

}  // namespace tamp
