// SPDX-License-Identifier: GPL-3.0-or-later
#include <sstream>
#include <stdexcept>

#include "core/io.hpp"
#include "core/validation.hpp"

// The CSV reader on a stream, apart from io.cpp so the fuzz target (fuzz/) links it alone.
namespace rbc {

CsvTable parse_csv(std::istream& in, const std::string& path) {
  CsvTable t;
  std::string line;
  int lineno = 0;
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
                                 c + "' is not a number");
      row.push_back(*v);
    }
    t.rows.push_back(std::move(row));
  }
  if (t.header.empty()) throw std::runtime_error("CSV file '" + path + "' has no header line");
  return t;
}

}  // namespace rbc
