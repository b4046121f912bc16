#include "core/Log.hpp"
#include <iostream>

namespace tamp::log {
namespace {
Level g_level = Level::Info;
}
void set_level(Level l) { g_level = l; }
Level level() { return g_level; }
void info(const std::string& msg) {
  if (g_level >= Level::Info) std::cerr << "[tamp] " << msg << "\n";
}
void warn(const std::string& msg) { std::cerr << "[tamp] warning: " << msg << "\n"; }
void error(const std::string& msg) { std::cerr << "[tamp] error: " << msg << "\n"; }
}  // namespace tamp::log
