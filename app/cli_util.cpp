#include "app/cli_util.hpp"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace rbc::app {

std::vector<double> parse_number_list(const std::string& text, const std::string& what,
                                      const std::string& example, bool allow_negative) {
  std::vector<double> out;
  if (text.find_first_not_of(" \t") == std::string::npos)
    throw std::invalid_argument("the " + what + " list is empty (expected e.g. " + example + ")");
  // Every comma separates two items: "16," and "16,,38" have an empty item.
  for (std::size_t begin = 0, end = 0; end != std::string::npos; begin = end + 1) {
    end = text.find(',', begin);
    const std::string item = text.substr(begin, end == std::string::npos ? end : end - begin);
    if (item.find_first_not_of(" \t") == std::string::npos)
      throw std::invalid_argument("the " + what + " list '" + text +
                                  "' has an empty item (expected e.g. " + example + ")");
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos)
      throw std::invalid_argument(what + " '" + item + "' is not a number (expected " + example +
                                  ")");
    if (!std::isfinite(v) || (!allow_negative && v < 0))
      throw std::invalid_argument(what + " " + item + " is not allowed: expected " +
                                  (allow_negative ? "a finite value" : "finite values >= 0") +
                                  ", e.g. " + example);
    out.push_back(v);
  }
  return out;
}

std::vector<double> parse_force_list(const std::string& text) {
  return parse_number_list(text, "force", "0,16,88 in pN", false);
}

ProgressSink stderr_progress(bool quiet) {
  if (quiet) return {};
  const auto start = std::chrono::steady_clock::now();
  return [start](const std::string& message) {
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cerr << "[" << std::fixed << std::setprecision(1) << std::setw(7) << t << " s] " << message
              << std::endl;
  };
}

}  // namespace rbc::app
