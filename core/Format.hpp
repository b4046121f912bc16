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

// Text as a one-line message can show it (a file name, a value read from a file or the
// command line): control characters (a newline in a name) and bytes that are not valid UTF-8
// escaped as \xNN, and anything beyond `max_chars` cut, with the length it had.
inline std::string printable(const std::string& text, size_t max_chars = 200) {
  std::string out;
  const size_t n = text.size();
  size_t i = 0, shown = 0;
  auto escape = [&](unsigned char c) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", c);
    out += buf;
  };
  while (i < n && shown < max_chars) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    // the length of a well-formed UTF-8 sequence starting here (0: not one)
    size_t len = 0;
    if (c >= 0x20 && c < 0x7f) len = 1;
    else if (c >= 0xc2 && c <= 0xdf) len = 2;
    else if (c >= 0xe0 && c <= 0xef) len = 3;
    else if (c >= 0xf0 && c <= 0xf4) len = 4;
    bool ok = len > 0 && i + len <= n;
    for (size_t k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(text[i + k]) & 0xc0) == 0x80;
    if (ok && len == 3) {  // no overlong forms, no surrogates
      const unsigned char c1 = static_cast<unsigned char>(text[i + 1]);
      ok = !(c == 0xe0 && c1 < 0xa0) && !(c == 0xed && c1 >= 0xa0);
    }
    if (ok && len == 4) {
      const unsigned char c1 = static_cast<unsigned char>(text[i + 1]);
      ok = !(c == 0xf0 && c1 < 0x90) && !(c == 0xf4 && c1 >= 0x90);
    }
    if (ok) {
      out.append(text, i, len);
      i += len;
    } else {
      escape(c);
      ++i;
    }
    ++shown;
  }
  if (i < n) out += "... (" + std::to_string(n) + " bytes)";
  return out;
}

}  // namespace tamp
