// The command line's validators: each numeric option declares its kind and range where it is
// declared (drivers/cli/main.cpp), so that a bad value is refused by one mechanism before any
// work, with one line naming the option, the value and what is allowed (docs/input-deck.md
// "Command-line options"). CLI11's own Range lets NaN through (every comparison with NaN is
// false) and takes "inf" for a double; these do not.
#pragma once
#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>
#include <string>

#include "core/Format.hpp"

namespace tamp::cli {

// A finite real number in [lo, hi].
inline CLI::Validator finite(double lo, double hi) {
  const std::string allowed = "a finite number from " + fmt_num(lo) + " to " + fmt_num(hi);
  return CLI::Validator(
      [lo, hi, allowed](std::string& text) -> std::string {
        double x = 0;
        const auto res = std::from_chars(text.data(), text.data() + text.size(), x);
        if (res.ec != std::errc() || res.ptr != text.data() + text.size() || !std::isfinite(x) || x < lo || x > hi)
          return "value '" + printable(text, 60) + "'; allowed: " + allowed;
        return {};
      },
      "FINITE in [" + fmt_num(lo) + ", " + fmt_num(hi) + "]", "finite");
}

// A whole number in [lo, hi] (the text an integer in decimal, no sign other than a leading '-').
inline CLI::Validator whole(long long lo, long long hi) {
  const std::string allowed = "a whole number from " + std::to_string(lo) + " to " + std::to_string(hi);
  return CLI::Validator(
      [lo, hi, allowed](std::string& text) -> std::string {
        long long x = 0;
        const auto res = std::from_chars(text.data(), text.data() + text.size(), x);
        if (res.ec != std::errc() || res.ptr != text.data() + text.size() || x < lo || x > hi)
          return "value '" + printable(text, 60) + "'; allowed: " + allowed;
        return {};
      },
      "INT in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", "whole");
}

}  // namespace tamp::cli
