// Minimal logging: messages to stderr with a level prefix; quiet mode for tests.
#pragma once
#include <string>

namespace tamp::log {
enum class Level { Quiet = 0, Info = 1, Debug = 2 };
void set_level(Level level);
Level level();
void info(const std::string& msg);
void warn(const std::string& msg);
void error(const std::string& msg);
}  // namespace tamp::log
