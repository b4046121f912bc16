#include "core/Log.hpp"
#include <iostream>
#include <mutex>

namespace tamp::log {
namespace {
Level g_level = Level::Info;
// one line at a time: the fits of a diagnosis log from threads of their own
// (ForwardRuns::side_by_side)
std::mutex g_line;
void line(const std::string& text) {
  std::lock_guard<std::mutex> g(g_line);
  std::cerr << text;
}
}  // namespace
void set_level(Level l) { g_level = l; }
Level level() { return g_level; }
void info(const std::string& msg) {
  if (g_level >= Level::Info) line("[tamp] " + msg + "\n");
}
void warn(const std::string& msg) { line("[tamp] warning: " + msg + "\n"); }
void error(const std::string& msg) { line("[tamp] error: " + msg + "\n"); }
}  // namespace tamp::log
