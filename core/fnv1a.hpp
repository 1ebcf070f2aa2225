// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// FNV-1a, 64 bits (Fowler, Noll and Vo; the parameters of the IETF draft
// draft-eastlake-fnv): a fast, non-cryptographic hash for fingerprints and content checksums of
// the project's own files. Written here because none of the project's dependencies exposes a
// plain 64-bit byte hash (zlib's crc32 has 32 bits and HDF5's Fletcher-32 covers chunked
// datasets only, not attributes); it guards against corruption, not against tampering.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

namespace rbc {

struct Fnv1a {
  std::uint64_t h = 0xcbf29ce484222325ull;  ///< offset basis
  void add(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) {
      h ^= p[i];
      h *= 0x100000001b3ull;  // FNV prime
    }
  }
  void add(const std::string& s) {
    const std::uint64_t n = s.size();
    add(&n, sizeof n);  // length first: "ab" + "c" and "a" + "bc" hash apart
    add(s.data(), s.size());
  }
};

/// Lower-case hexadecimal digits of `v` (no leading zeros, no prefix).
inline std::string hex_digits(std::uint64_t v) {
  std::ostringstream s;
  s << std::hex << v;
  return s.str();
}

}  // namespace rbc
