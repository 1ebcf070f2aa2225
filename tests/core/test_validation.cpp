// SPDX-License-Identifier: GPL-3.0-or-later
// core/validation.hpp: the one shared check every options struct's validate() uses.
#include "core/validation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

#include "core/io.hpp"
#include "test_output.hpp"

namespace {
using rbc::Ends;
using rbc::InvalidParameter;
constexpr double inf = std::numeric_limits<double>::infinity();
const double nan = std::nan("");

/// The message of the InvalidParameter thrown by f (fails the test when none is thrown).
template <class F>
std::string message_of(F f) {
  try {
    f();
  } catch (const InvalidParameter& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InvalidParameter thrown";
  return {};
}

TEST(Validation, FormatsNumbersIndependentlyOfStreams) {
  EXPECT_EQ(rbc::format_number(75.0), "75");
  EXPECT_EQ(rbc::format_number(0.005), "0.005");
  EXPECT_EQ(rbc::format_number(1e308), "1e+308");
  EXPECT_EQ(rbc::format_number(inf), "inf");
  EXPECT_EQ(rbc::format_number(-inf), "-inf");
  EXPECT_EQ(rbc::format_number(nan), "nan");
  EXPECT_EQ(rbc::format_scientific(6.0123e-5), "6.012e-05");
  EXPECT_EQ(rbc::format_scientific(-3.7e-4), "-3.700e-04");
}

TEST(Validation, MessageNamesQuantityExpectationAndValue) {
  EXPECT_EQ(message_of(
                [] { rbc::require_finite_in_range("persistence length", "nm", inf, 0.0, 1000.0); }),
            "persistence length must be finite and in (0, 1000] nm, got inf");
  EXPECT_EQ(message_of([] { rbc::require_finite_in_range("Lbar", "nm", 0.0, 0.0, 1000.0); }),
            "Lbar must be finite and in (0, 1000] nm, got 0 nm");
  EXPECT_EQ(message_of([] {
              rbc::require_finite_in_range("stiffness", "pN/um^3", -1.0, 0.0, rbc::kUnbounded);
            }),
            "stiffness must be finite and > 0 pN/um^3, got -1 pN/um^3");
  EXPECT_EQ(message_of([] { rbc::require_integer_in_range("max iterations", -5, 1, 100); }),
            "max iterations must be an integer in [1, 100], got -5");
  // The parts are kept apart for front ends that name their own option.
  try {
    rbc::require_finite_in_range("temperature", "K", 2000.0, 0.0, 1000.0);
    FAIL();
  } catch (const InvalidParameter& e) {
    EXPECT_EQ(e.quantity(), "temperature");
    EXPECT_EQ(e.value(), "2000");
    EXPECT_EQ(e.expectation(), "finite and in (0, 1000] K");
  }
}

TEST(Validation, EveryEndOfTheIntervalAsDocumented) {
  auto ok = [](double v, double lo, double hi, Ends ends) {
    try {
      rbc::require_finite_in_range("x", "", v, lo, hi, ends);
      return true;
    } catch (const InvalidParameter&) {
      return false;
    }
  };
  EXPECT_FALSE(ok(0.0, 0.0, 1.0, Ends::open_closed));
  EXPECT_TRUE(ok(1.0, 0.0, 1.0, Ends::open_closed));
  EXPECT_TRUE(ok(0.0, 0.0, 1.0, Ends::closed_closed));
  EXPECT_FALSE(ok(1.0, 0.0, 1.0, Ends::closed_open));
  EXPECT_FALSE(ok(0.0, 0.0, 1.0, Ends::open_open));
  EXPECT_TRUE(ok(0.5, 0.0, 1.0, Ends::open_open));
  // Non-finite values fail every check, even an unbounded one.
  for (double bad : {inf, -inf, nan}) {
    EXPECT_FALSE(ok(bad, 0.0, 1.0, Ends::closed_closed));
    EXPECT_FALSE(ok(bad, -rbc::kUnbounded, rbc::kUnbounded, Ends::open_open));
  }
  EXPECT_EQ(rbc::range_expectation(-rbc::kUnbounded, rbc::kUnbounded, Ends::open_open, ""),
            "finite");
  EXPECT_EQ(rbc::range_expectation(0.0, rbc::kUnbounded, Ends::closed_open, "pN um"),
            "finite and >= 0 pN um");
  // An InvalidParameter is a std::invalid_argument: existing callers keep catching it.
  EXPECT_THROW(rbc::require_finite_in_range("x", "", nan, 0, 1), std::invalid_argument);
}

// The one number reader of the front ends: the whole text or nothing, locale-independent.
TEST(Validation, NumberReadersTakeTheWholeTextOrNothing) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::pair<const char*, double> good[] = {
      {"1.5", 1.5}, {" 2 ", 2.0},     {"\t+3", 3.0},        {"1e3", 1000.0},
      {".5", 0.5},  {"-0.25", -0.25}, {"6.02e-5", 6.02e-5}, {"5.", 5.0}};
  for (const auto& [text, value] : good) {
    SCOPED_TRACE(text);
    ASSERT_TRUE(rbc::parse_finite_number(text).has_value());
    EXPECT_EQ(*rbc::parse_finite_number(text), value);
    EXPECT_EQ(*rbc::parse_number(text), value);
  }
  for (const char* bad : {"", " ", "1x", "1,5", "1 2", "--1", "+-1", "++1", "+", "0x10", "1e",
                          "1e999", "abc", "1%"}) {
    SCOPED_TRACE(bad);
    EXPECT_FALSE(rbc::parse_number(bad).has_value());
    EXPECT_FALSE(rbc::parse_finite_number(bad).has_value());
  }
  // inf and nan are numbers (a CSV cell may hold one; its reader's caller refuses it by name)
  // but not finite ones.
  EXPECT_EQ(*rbc::parse_number("inf"), inf);
  EXPECT_EQ(*rbc::parse_number("-inf"), -inf);
  EXPECT_TRUE(std::isnan(*rbc::parse_number("nan")));
  for (const char* nonfinite : {"inf", "-inf", "nan", "infinity"})
    EXPECT_FALSE(rbc::parse_finite_number(nonfinite).has_value()) << nonfinite;

  EXPECT_EQ(*rbc::parse_integer(" 42 "), 42);
  EXPECT_EQ(*rbc::parse_integer("+7"), 7);
  EXPECT_EQ(*rbc::parse_integer("-3"), -3);
  for (const char* bad : {"", "4.0", "1e3", "12a", "99999999999999999999", "--1", "0x1F"})
    EXPECT_FALSE(rbc::parse_integer(bad).has_value()) << bad;
}

// ---- data-file reader messages (core/csv.cpp) ----

/// The runtime_error message of f, checked to be whole: what() as a C string is the full text
/// (no NUL inside) and every byte is printable ASCII.
template <class F>
std::string read_error(F f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    const std::string text = e.what();
    EXPECT_EQ(std::strlen(e.what()), text.size());
    for (unsigned char c : text) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << int(c) << " in " << text;
    return text;
  }
  ADD_FAILURE() << "no std::runtime_error thrown";
  return "";
}

// A leading text column names the rows; a label holding a comma or a quote is quoted (RFC 4180),
// so a standard CSV reader gets the label back whole.
TEST(CsvLabels, RowsNamedInALeadingQuotedColumn) {
  const auto dir = rbc::testing::fresh_output_dir("csv_labels");
  rbc::CsvTable t;
  t.comments = {"two methods"};
  t.label_header = "method";
  t.header = {"error_percent"};
  t.labels = {"discrete_N2000", "continuum, \"full\" law"};
  t.rows = {{0.5}, {1.25}};
  rbc::write_csv((dir / "t.csv").string(), t);
  std::ifstream in(dir / "t.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(),
            "# two methods\nmethod,error_percent\ndiscrete_N2000,0.5\n"
            "\"continuum, \"\"full\"\" law\",1.25\n");
  // read back: the labels unquoted, the numbers as written
  const rbc::CsvTable back = rbc::read_csv((dir / "t.csv").string(), rbc::CsvLabels::first_column);
  EXPECT_EQ(back.label_header, "method");
  EXPECT_EQ(back.labels, t.labels);
  EXPECT_EQ(back.header, t.header);
  EXPECT_EQ(back.rows, t.rows);
  t.labels.pop_back();  // a label per row, or the table is not written
  EXPECT_THROW(rbc::write_csv((dir / "u.csv").string(), t), std::logic_error);
  EXPECT_FALSE(std::filesystem::exists(dir / "u.csv"));
}

TEST(CsvMessages, ADirectoryIsNamedAsOne) {
  const auto dir = rbc::testing::fresh_output_dir("csv_messages_directory");
  const std::string expected =
      "CSV file '" + dir.string() + "' is a directory, expected a CSV file";
  EXPECT_EQ(read_error([&] { rbc::read_csv(dir.string()); }), expected);
  EXPECT_EQ(read_error([&] { rbc::check_csv_file(dir.string()); }), expected);
  // A stream opened on the directory (the first read fails with EISDIR): the same words.
  std::ifstream in(dir);
  EXPECT_EQ(read_error([&] { rbc::parse_csv(in, dir.string()); }), expected);
}

TEST(CsvMessages, AMissingFileNamesTheSystemsCause) {
  const auto dir = rbc::testing::fresh_output_dir("csv_messages_missing");
  const std::string missing = (dir / "no_such.csv").string();
  EXPECT_EQ(read_error([&] { rbc::read_csv(missing); }),
            "cannot open CSV file '" + missing + "': " + std::strerror(ENOENT));
  const std::string below_a_file = (dir / "plain.csv" / "x.csv").string();
  std::ofstream(dir / "plain.csv") << "a,b\n1,2\n";
  EXPECT_EQ(read_error([&] { rbc::read_csv(below_a_file); }),
            "cannot open CSV file '" + below_a_file + "': " + std::strerror(ENOTDIR));
  EXPECT_EQ(rbc::read_csv((dir / "plain.csv").string()).rows.size(), 1u);
}

TEST(CsvMessages, BytesFromTheFileAreEscapedNotCutAtANul) {
  std::string text = "a,b\n1,2";
  text += '\0';
  text += "3\n";
  std::istringstream in(text);
  EXPECT_EQ(read_error([&] { rbc::parse_csv(in, "nul.csv"); }),
            "CSV file 'nul.csv' line 2: '2\\x003' is not a number");
  std::istringstream control("a,b\n1,\x1b[31m\xff\\\n");
  EXPECT_EQ(read_error([&] { rbc::parse_csv(control, "c.csv"); }),
            "CSV file 'c.csv' line 2: '\\x1b[31m\\xff\\x5c' is not a number");
  std::istringstream long_cell("a\n" + std::string(200, 'z') + "\n");
  const std::string m = read_error([&] { rbc::parse_csv(long_cell, "l.csv"); });
  EXPECT_NE(m.find("'" + std::string(60, 'z') + "...' is not a number"), std::string::npos) << m;
}

}  // namespace

namespace rbc {
namespace {

// A mean printed to its error's significance: the error's two significant digits fix the
// decimals of both (the rounding rule of the Particle Data Group's tables, two digits always).
TEST(FormatWithError, TheErrorKeepsTwoSignificantDigitsAndTheMeanItsDecimals) {
  EXPECT_EQ(format_with_error(11.62671, 0.00331516), "11.6267 +- 0.0033");
  EXPECT_EQ(format_with_error(181.4, 12.6), "181 +- 13");
  EXPECT_EQ(format_with_error(1234.5, 250.0), "1230 +- 250");
  EXPECT_EQ(format_with_error(2.0, 1.0), "2.0 +- 1.0");
  EXPECT_EQ(format_with_error(0.5, 0.0999), "0.50 +- 0.10");  // rounds up into the next decade
  EXPECT_EQ(format_with_error(-3.14159, 0.012), "-3.142 +- 0.012");
  EXPECT_EQ(format_with_error(11.6267, 0.0), "11.6267 +- 0");
  EXPECT_EQ(format_with_error(11.6267, std::numeric_limits<double>::quiet_NaN()), "11.6267 +- nan");
}

}  // namespace
}  // namespace rbc
