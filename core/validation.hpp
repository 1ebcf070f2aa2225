// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Checks of caller-supplied parameters, shared by every options struct's validate() so that
// every message reads the same way: the quantity, what was expected, the value received, e.g.
//   "persistence length must be finite and in (0, 1000] nm, got inf".
// Messages state values in the units the caller chose (nm for spectrin lengths, J for kappa)
// where the struct holds internal units: the struct converts before calling.
//
// The thrown InvalidParameter is a std::invalid_argument that also keeps the quantity, the
// value as printed and the expectation apart, so a front end can name its own option for the
// quantity ("--persistence inf: persistence length must be finite and in (0, 1000] nm").
// Comparisons are written so that NaN fails every check (a NaN is never "in range").
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rbc {

class InvalidParameter : public std::invalid_argument {
 public:
  /// what() = quantity + " must be " + expectation + ", got " + value (+ " " + unit when
  /// the value is a finite number: "got 0 nm", but "got inf").
  InvalidParameter(const std::string& quantity, const std::string& value,
                   const std::string& expectation, const std::string& unit = "");
  const std::string& quantity() const { return quantity_; }
  const std::string& value() const { return value_; }  ///< as printed, without unit
  const std::string& expectation() const { return expectation_; }

 private:
  std::string quantity_, value_, expectation_;
};

/// Which ends belong to an interval [lo, hi]: open_closed is (lo, hi], and so on.
enum class Ends { open_closed, closed_closed, open_open, closed_open };

/// A number for messages, independent of any stream's formatting state: up to 6 significant
/// digits in %g style ("75", "0.005", "1e+308"), and "inf", "-inf", "nan".
std::string format_number(double value);

/// A number in scientific notation with 3 decimals ("6.012e-05"), for residuals and drifts.
std::string format_scientific(double value);

/// A mean and its statistical error to the error's significance: the error with two significant
/// digits, the mean to the same decimal place (11.62671, 0.00331516 -> "11.6267 +- 0.0033";
/// 181.4, 12.6 -> "181 +- 13"). A zero or non-finite error leaves the mean at 6 significant
/// digits ("11.6267 +- 0").
std::string format_with_error(double mean, double error);

/// The expectation text of a range: "finite and in (0, 1000] nm"; an infinite hi gives
/// "finite and > 0 nm" (or ">= 0"), an infinite lo "finite and <= hi". unit may be empty.
std::string range_expectation(double lo, double hi, Ends ends, const std::string& unit);

/// Throws InvalidParameter unless value is finite and inside the interval.
void require_finite_in_range(const std::string& quantity, const std::string& unit, double value,
                             double lo, double hi, Ends ends = Ends::open_closed);

/// Throws InvalidParameter unless lo <= value <= hi ("an integer in [1, 10000000]").
void require_integer_in_range(const std::string& quantity, long long value, long long lo,
                              long long hi);

/// +infinity, for an unbounded end of range_expectation / require_finite_in_range.
/// The whole of `text` read as a real number, independently of the C locale (std::from_chars):
/// blanks (space, tab) around it and one leading '+' are accepted, as are "inf" and "nan"; an
/// empty text, trailing characters and out-of-range values give std::nullopt.
std::optional<double> parse_number(std::string_view text);

/// The whole of `text` read as a finite real number, independently of the C locale
/// (std::from_chars): blanks (space, tab) around it and one leading '+' are accepted; an empty
/// text, trailing characters, "inf", "nan" and out-of-range values give std::nullopt. The one
/// number reader of every front end (option lists, prior boxes, accuracy percentages).
std::optional<double> parse_finite_number(std::string_view text);

/// The whole of `text` read as a decimal integer (blanks around it and one leading '+'
/// accepted); anything else, or a value outside long long, gives std::nullopt.
std::optional<long long> parse_integer(std::string_view text);

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

}  // namespace rbc
