#pragma once
// The one channel through which library code reports progress; drivers decide where it
// goes (stderr for the CLI, nowhere in tests). Library code never prints.
#include <functional>
#include <string>

namespace rbc {
using ProgressSink = std::function<void(const std::string& message)>;
inline void report(const ProgressSink& sink, const std::string& message) {
  if (sink) sink(message);
}
}  // namespace rbc
