// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/cli_util.hpp"

#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/validation.hpp"

namespace rbc::app {

namespace {
/// "--force" -> "force": the list's name in messages.
std::string list_noun(const std::string& option) {
  return option.rfind("--", 0) == 0 ? option.substr(2) : option;
}
}  // namespace

std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& example, bool allow_negative) {
  const std::string expected = std::string("expected a comma-separated list of finite numbers") +
                               (allow_negative ? "" : " >= 0") + " (e.g. " + example + ")";
  std::vector<double> out;
  if (text.find_first_not_of(" \t") == std::string::npos)
    throw std::invalid_argument(option + " '" + text + "': the " + list_noun(option) +
                                " list is empty; " + expected);
  // Every comma separates two items: "16," and "16,,38" name the empty item.
  for (std::size_t begin = 0, end = 0; end != std::string::npos; begin = end + 1) {
    end = text.find(',', begin);
    const std::string item = text.substr(begin, end == std::string::npos ? end : end - begin);
    if (item.find_first_not_of(" \t") == std::string::npos)
      throw std::invalid_argument(option + " '" + text + "': the " + list_noun(option) +
                                  " list has an empty item; " + expected);
    const std::optional<double> parsed = parse_number(item);
    if (!parsed)
      throw std::invalid_argument(option + " " + text + ": '" + item + "' is not a number; " +
                                  expected);
    const double v = *parsed;
    if (!std::isfinite(v) || (!allow_negative && v < 0))
      throw std::invalid_argument(option + " " + text + ": " + item + " is not allowed; " +
                                  expected);
    out.push_back(v + 0.0);  // -0 -> +0
  }
  return out;
}

std::vector<double> parse_force_list(const std::string& text) {
  return parse_number_list(text, "--force", "0,16,88 in pN", false);
}

ProgressSink stderr_progress(bool quiet) {
  if (quiet) return {};
  const auto start = std::chrono::steady_clock::now();
  return [start](const std::string& message) {
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::ostringstream line;  // its own format state: std::cerr's stays as it was
    line << "[" << std::fixed << std::setprecision(1) << std::setw(7) << t << " s] " << message
         << "\n";
    std::cerr << line.str() << std::flush;
  };
}

int naming_options(const OptionNames& names, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InvalidParameter& e) {
    const auto it = names.find(e.quantity());
    if (it == names.end()) throw;
    throw std::invalid_argument(it->second + " " + e.value() + ": " + e.quantity() + " must be " +
                                e.expectation());
  }
}

namespace {
template <class Int>
std::string check_integer(const std::string& text, Int lo, Int hi) {
  const std::string expected =
      "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  Int v{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);  // no blanks, no '+': as typed
  if (text.empty() || ec != std::errc() || ptr != end || v < lo || v > hi)
    return text + ": " + expected;
  return {};
}
}  // namespace

CLI::Validator integer_in(long long lo, long long hi) {
  return CLI::Validator([lo, hi](std::string& s) { return check_integer<long long>(s, lo, hi); },
                        "INT in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

CLI::Validator unsigned_integer() {
  return CLI::Validator(
      [](std::string& s) {
        return check_integer<unsigned long long>(s, 0ull,
                                                 std::numeric_limits<unsigned long long>::max());
      },
      "UINT64");
}

namespace {
namespace fs = std::filesystem;

/// Creates the directory if needed and proves it writable with a probe file.
void probe_writable(const std::string& dir, const std::string& option) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw std::invalid_argument(option + " " + dir + ": cannot create the directory" +
                                (ec ? " (" + ec.message() + ")" : ""));
  const fs::path probe = fs::path(dir) / (".rbc-write-probe-" + std::to_string(getpid()));
  std::FILE* f = std::fopen(probe.c_str(), "w");
  if (!f || access(dir.c_str(), W_OK) != 0) {
    if (f) std::fclose(f);
    fs::remove(probe, ec);
    throw std::invalid_argument(option + " " + dir + ": the directory is not writable");
  }
  std::fclose(f);
  fs::remove(probe, ec);
}
}  // namespace

void prepare_output_directory(const std::string& dir, bool overwrite, bool allow_nonempty,
                              const std::string& option) {
  if (dir.empty()) throw std::invalid_argument(option + " '': expected a directory");
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw std::invalid_argument(option + " " + dir + ": exists and is not a directory");
  if (fs::is_directory(dir, ec) && !fs::is_empty(dir, ec) && !overwrite && !allow_nonempty)
    throw std::invalid_argument(option + " " + dir +
                                ": the directory is not empty; choose another or pass "
                                "--force-overwrite");
  probe_writable(dir, option);
}

void check_output_file(const std::string& path, const std::string& option) {
  if (path.empty()) throw std::invalid_argument(option + " '': expected a file name");
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw std::invalid_argument(option + " " + path + ": is a directory, expected a file");
  fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) parent = ".";
  probe_writable(parent.string(), option + " " + path + ": its directory");
}

std::string number_tag(double value, int min_decimals) {
  for (int d = min_decimals;; ++d) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(d) << value;
    if (std::stod(s.str()) == value || d >= 20) return s.str();
  }
}

void require_distinct(const std::vector<double>& values, const std::string& option,
                      const std::string& text) {
  for (size_t i = 0; i < values.size(); ++i)
    for (size_t j = i + 1; j < values.size(); ++j)
      if (values[i] == values[j])
        throw std::invalid_argument(option + " " + text + ": values must be distinct, " +
                                    format_number(values[i]) +
                                    " appears twice and would write the same files twice");
}

}  // namespace rbc::app
