// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/validation.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace rbc {

namespace {
/// text without surrounding blanks and without one leading '+' (from_chars takes neither).
std::string_view number_body(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  text = text.substr(first, text.find_last_not_of(" \t") - first + 1);
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+')
    text.remove_prefix(1);
  return text;
}

std::string value_with_unit(const std::string& value, const std::string& unit) {
  const bool number = value != "inf" && value != "-inf" && value != "nan";
  return unit.empty() || !number ? value : value + " " + unit;
}
}  // namespace

InvalidParameter::InvalidParameter(const std::string& quantity, const std::string& value,
                                   const std::string& expectation, const std::string& unit)
    : std::invalid_argument(quantity + " must be " + expectation + ", got " +
                            value_with_unit(value, unit)),
      quantity_(quantity),
      value_(value),
      expectation_(expectation) {}

namespace {
std::string printf_number(const char* format, double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof buf, format, value);
  return buf;
}
}  // namespace

std::string format_number(double value) {
  return printf_number("%.6g", value);
}

std::string format_scientific(double value) {
  return printf_number("%.3e", value);
}

std::string format_with_error(double mean, double error) {
  if (!(error > 0) || !std::isfinite(error) || !std::isfinite(mean))
    return format_number(mean) + " +- " + format_number(error);
  // Two significant digits of the error: its leading digit's decade, after rounding.
  int decade = static_cast<int>(std::floor(std::log10(error)));
  if (std::round(error / std::pow(10.0, decade - 1)) >= 100.0) ++decade;  // 0.0999 -> 0.10
  const int decimals = std::max(0, 1 - decade);
  if (decimals == 0) {
    const double unit = std::pow(10.0, decade - 1);  // round both to the error's second digit
    return printf_number("%.0f", std::round(mean / unit) * unit) + " +- " +
           printf_number("%.0f", std::round(error / unit) * unit);
  }
  const std::string format = "%." + std::to_string(decimals) + "f";
  return printf_number(format.c_str(), mean) + " +- " + printf_number(format.c_str(), error);
}

std::string range_expectation(double lo, double hi, Ends ends, const std::string& unit) {
  const bool lo_open = ends == Ends::open_closed || ends == Ends::open_open;
  const bool hi_open = ends == Ends::open_open || ends == Ends::closed_open;
  std::string text = "finite and ";
  if (std::isinf(hi) && std::isinf(lo))
    text = "finite";
  else if (std::isinf(hi))
    text += (lo_open ? "> " : ">= ") + format_number(lo);
  else if (std::isinf(lo))
    text += (hi_open ? "< " : "<= ") + format_number(hi);
  else
    text += std::string("in ") + (lo_open ? "(" : "[") + format_number(lo) + ", " +
            format_number(hi) + (hi_open ? ")" : "]");
  if (!unit.empty()) text += " " + unit;
  return text;
}

void require_finite_in_range(const std::string& quantity, const std::string& unit, double value,
                             double lo, double hi, Ends ends) {
  const bool lo_open = ends == Ends::open_closed || ends == Ends::open_open;
  const bool hi_open = ends == Ends::open_open || ends == Ends::closed_open;
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  if (!(std::isfinite(value) && above && below))
    throw InvalidParameter(quantity, format_number(value), range_expectation(lo, hi, ends, unit),
                           unit);
}

void require_integer_in_range(const std::string& quantity, long long value, long long lo,
                              long long hi) {
  if (value < lo || value > hi)
    throw InvalidParameter(
        quantity, std::to_string(value),
        "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

std::optional<double> parse_number(std::string_view text) {
  const std::string_view body = number_body(text);
  if (body.empty()) return std::nullopt;
  double v = 0;
  const char* end = body.data() + body.size();
  const auto [ptr, ec] = std::from_chars(body.data(), end, v);
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return v;
}

std::optional<double> parse_finite_number(std::string_view text) {
  const std::optional<double> v = parse_number(text);
  if (!v || !std::isfinite(*v)) return std::nullopt;
  return v;
}

std::optional<long long> parse_integer(std::string_view text) {
  const std::string_view body = number_body(text);
  if (body.empty()) return std::nullopt;
  long long v = 0;
  const char* end = body.data() + body.size();
  const auto [ptr, ec] = std::from_chars(body.data(), end, v);
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return v;
}

}  // namespace rbc
