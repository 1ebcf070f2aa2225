// SPDX-License-Identifier: GPL-3.0-or-later
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include "core/io.hpp"
#include "core/validation.hpp"

// The CSV reader on a stream, apart from io.cpp so the fuzz target (fuzz/) links it alone.
namespace rbc {

/// Text taken from a file, fit for a one-line message: printable ASCII as it is, every other
/// byte (NUL, control characters, non-ASCII) as \xNN, so a message is never cut at a NUL or
/// broken by a control character; at most 60 bytes of the text are shown.
std::string printable(std::string_view text) {
  constexpr std::size_t kShown = 60;
  std::string out;
  for (std::size_t i = 0; i < text.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  if (text.size() > kShown) out += "...";
  return out;
}

std::size_t find_word(std::string_view text, std::string_view word, std::size_t from) {
  auto letter = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
  for (std::size_t at = text.find(word, from); at != std::string_view::npos;
       at = text.find(word, at + 1)) {
    const std::size_t end = at + word.size();
    if ((at == 0 || !letter(text[at - 1])) && (end == text.size() || !letter(text[end]))) return at;
  }
  return std::string_view::npos;
}

namespace {

std::runtime_error is_a_directory(const std::string& path) {
  return std::runtime_error("CSV file '" + path + "' is a directory, expected a CSV file");
}

}  // namespace

void check_csv_file(const std::string& path) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (!ec && std::filesystem::is_directory(st)) throw is_a_directory(path);
  // A pipe or device is read as it comes (opening a FIFO here would wait for its writer).
  if (!ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st)) return;
  // The system says why a file cannot be opened (ENOENT, ENOTDIR, EACCES, ELOOP, ...).
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "r");
  if (!f) {
    const int err = errno;
    throw std::runtime_error("cannot open CSV file '" + path +
                             "': " + (err ? std::strerror(err) : "unknown error"));
  }
  std::fclose(f);
}

namespace {

/// Splits off the first cell of `line` (RFC 4180: a quoted cell may hold commas and doubled
/// quotes); returns false for an unterminated quote.
bool take_first_cell(std::string& line, std::string& cell) {
  cell.clear();
  if (line.empty() || line[0] != '"') {
    const auto comma = line.find(',');
    cell = line.substr(0, comma);
    line = comma == std::string::npos ? "" : line.substr(comma + 1);
    return true;
  }
  std::size_t k = 1;
  for (; k < line.size(); ++k) {
    if (line[k] != '"') {
      cell += line[k];
    } else if (k + 1 < line.size() && line[k + 1] == '"') {
      cell += '"';
      ++k;
    } else {
      break;
    }
  }
  if (k >= line.size()) return false;  // no closing quote
  line = k + 1 < line.size() && line[k + 1] == ',' ? line.substr(k + 2) : line.substr(k + 1);
  return true;
}

}  // namespace

CsvTable parse_csv(std::istream& in, const std::string& path, CsvLabels labels) {
  CsvTable t;
  std::string line;
  int lineno = 0;
  errno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == '#') {
      t.comments.push_back(line.substr(line.find_first_not_of("# ") == std::string::npos
                                           ? line.size()
                                           : line.find_first_not_of("# ")));
      continue;
    }
    if (labels == CsvLabels::first_column) {
      std::string label;
      if (!take_first_cell(line, label))
        throw std::runtime_error("CSV file '" + path + "' line " + std::to_string(lineno) +
                                 ": a quoted label without its closing quote");
      if (t.header.empty() && t.label_header.empty())
        t.label_header = label;
      else
        t.labels.push_back(label);
    }
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (t.header.empty()) {
      t.header = cells;
      continue;
    }
    if (cells.size() != t.header.size())
      throw std::runtime_error("CSV file '" + path + "' line " + std::to_string(lineno) + ": " +
                               std::to_string(cells.size()) + " values, expected " +
                               std::to_string(t.header.size()));
    std::vector<double> row;
    for (const auto& c : cells) {
      const std::optional<double> v = parse_number(c);
      if (!v)
        throw std::runtime_error("CSV file '" + path + "' line " + std::to_string(lineno) + ": '" +
                                 printable(c) + "' is not a number");
      row.push_back(*v);
    }
    t.rows.push_back(std::move(row));
  }
  if (in.bad()) {
    // A read error (the stream of a directory fails with EISDIR on its first read).
    const int err = errno;
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw is_a_directory(path);
    throw std::runtime_error("CSV file '" + path + "' could not be read after line " +
                             std::to_string(lineno) + ": " +
                             (err ? std::strerror(err) : "read error"));
  }
  if (t.header.empty()) throw std::runtime_error("CSV file '" + path + "' has no header line");
  return t;
}

}  // namespace rbc
