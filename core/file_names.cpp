// SPDX-License-Identifier: GPL-3.0-or-later
// The parts of the output layer (core/io.hpp) that only name files: what kind a path is, and a
// number as a file-name tag. Apart from the writers so that code checking names (the CLI's option
// checks, their fuzz target) needs no HDF5.
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/io.hpp"

namespace rbc {

std::string non_regular_kind(const std::string& path) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return {};
    throw std::runtime_error(path + ": " + std::strerror(errno));
  }
  switch (st.st_mode & S_IFMT) {
    case S_IFREG:
      return {};
    case S_IFCHR:
      return "a character device";
    case S_IFBLK:
      return "a block device";
    case S_IFIFO:
      return "a FIFO";
    case S_IFSOCK:
      return "a socket";
    case S_IFDIR:
      return "a directory";
    case S_IFLNK:
      return "a symbolic link";
    default:
      return "not a regular file";
  }
}

std::string number_file_tag(double value, int min_decimals) {
  // Read back with strtod (std::stod refuses subnormals as out of range).
  auto reads_back = [value](const std::string& s) {
    return std::strtod(s.c_str(), nullptr) == value;
  };
  if (std::isfinite(value)) {
    for (int d = std::max(min_decimals, 0); d <= 20; ++d) {
      std::ostringstream s;
      s << std::fixed << std::setprecision(d) << value;
      if (s.str().size() > 24) break;
      if (reads_back(s.str())) return s.str();
    }
  }
  std::array<char, 64> buf{};
  const auto [end, ec] =
      std::to_chars(buf.data(), buf.data() + buf.size(), value, std::chars_format::scientific);
  return ec == std::errc() ? std::string(buf.data(), end) : std::string("nan");
}

}  // namespace rbc
