// SPDX-License-Identifier: GPL-3.0-or-later
// The output layer (core/io.hpp, core/h5file.hpp): file-name tags that read back as the same
// double, the PNG completeness check, commits that never replace anything but a regular file,
// and writes that report a full disk by its cause and leave no file and no HDF5 object open.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "core/h5file.hpp"
#include "core/io.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

bool reads_back(const std::string& tag, double value) {
  return std::strtod(tag.c_str(), nullptr) == value;
}

TEST(NumberFileTag, OrdinaryValuesKeepTheirShortFixedTags) {
  EXPECT_EQ(number_file_tag(16.0, 1), "16.0");
  EXPECT_EQ(number_file_tag(16.01, 1), "16.01");
  EXPECT_EQ(number_file_tag(0.0, 1), "0.0");
  EXPECT_EQ(number_file_tag(38.5, 1), "38.5");
  EXPECT_EQ(number_file_tag(0.1, 3), "0.100");
  EXPECT_EQ(number_file_tag(400.0, 1), "400.0");
}

TEST(NumberFileTag, TinyDistinctValuesGetDistinctTags) {
  const std::string a = number_file_tag(1e-300, 1), b = number_file_tag(1e-299, 1);
  EXPECT_NE(a, b);
  EXPECT_TRUE(reads_back(a, 1e-300)) << a;
  EXPECT_TRUE(reads_back(b, 1e-299)) << b;
  EXPECT_EQ(a, "1e-300");
}

// Property: every finite double's tag reads back as that double (so distinct values never
// share a file name), is short enough for a file name and holds no path separator.
TEST(NumberFileTag, EveryFiniteDoubleRoundTrips) {
  std::vector<double> values = {std::numeric_limits<double>::denorm_min(),
                                2 * std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::min(),
                                std::nextafter(std::numeric_limits<double>::min(), 0.0),
                                std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::epsilon(),
                                1e-21,
                                1e-20,
                                0.1 + 0.2,
                                1.0 / 3.0,
                                123456789.123456789,
                                1e22,
                                9007199254740993.0};
  std::mt19937_64 rng(20240521);
  for (int k = 0; k < 20000; ++k) {
    double v = 0;
    const std::uint64_t bits = rng();
    std::memcpy(&v, &bits, sizeof v);  // every exponent, subnormals included
    if (std::isfinite(v)) values.push_back(v);
    values.push_back(std::ldexp(static_cast<double>(rng() % 100000) / 1000.0,
                                static_cast<int>(rng() % 40) - 20));  // near ordinary forces
  }
  std::set<std::string> tags;
  std::set<double> distinct;
  for (double v : values)
    for (int decimals : {1, 3}) {
      const std::string tag = number_file_tag(v, decimals);
      ASSERT_TRUE(reads_back(tag, v)) << "value " << v << " tag " << tag;
      ASSERT_LE(tag.size(), 32u) << tag;
      ASSERT_EQ(tag.find('/'), std::string::npos) << tag;
      if (decimals == 1) {
        tags.insert(tag);
        distinct.insert(v == 0 ? 0.0 : v);
      }
    }
  EXPECT_EQ(tags.size(), distinct.size());
}

std::string real_png() {
  return read_all(fs::path(RBC_SOURCE_DIR) / "data/calibration/mills2004_fig8_p2_E500/corner.png");
}

TEST(PngCheck, ACompletePngPassesAndATruncatedOneFails) {
  const fs::path dir = testing::fresh_output_dir("output_layer_png");
  const std::string png = real_png();
  ASSERT_GT(png.size(), 100u);
  write_bytes(dir / "whole.png", png);
  EXPECT_TRUE(png_is_complete((dir / "whole.png").string()));
  // Cut where a full disk cuts (a block boundary) and one byte short of the end.
  write_bytes(dir / "cut.png", png.substr(0, 4096));
  EXPECT_FALSE(png_is_complete((dir / "cut.png").string()));
  write_bytes(dir / "short.png", png.substr(0, png.size() - 1));
  EXPECT_FALSE(png_is_complete((dir / "short.png").string()));
  write_bytes(dir / "nosig.png", "X" + png.substr(1));
  EXPECT_FALSE(png_is_complete((dir / "nosig.png").string()));
  write_bytes(dir / "empty.png", "");
  EXPECT_FALSE(png_is_complete((dir / "empty.png").string()));
  EXPECT_FALSE(png_is_complete((dir / "missing.png").string()));
}

TEST(Commit, NeverReplacesAFifoASymlinkOrADirectory) {
  const fs::path dir = testing::fresh_output_dir("output_layer_commit");
  const fs::path fifo = dir / "fifo", link = dir / "link", sub = dir / "sub",
                 target = dir / "target.txt";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0666), 0);
  write_bytes(target, "keep");
  fs::create_symlink(target, link);
  fs::create_directory(sub);
  for (const auto& [path, kind] : {std::pair{fifo, "a FIFO"}, std::pair{link, "a symbolic link"},
                                   std::pair{sub, "a directory"}}) {
    try {
      write_text_atomic(path.string(), "new");
      ADD_FAILURE() << path << " was replaced";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(path.string() + ": is " + kind +
                                           ", expected a regular file or nothing"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(fifo)));
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(link)));
  EXPECT_TRUE(fs::is_directory(fs::symlink_status(sub)));
  EXPECT_EQ(read_all(target), "keep");
  // The commit refuses too when the special file appears after the temporary was written.
  {
    TempFile tmp((dir / "late").string());
    write_bytes(tmp.path(), "new");
    ASSERT_EQ(mkfifo((dir / "late").c_str(), 0666), 0);
    EXPECT_THROW(tmp.commit(), std::runtime_error);
  }
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(dir / "late")));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
}

TEST(Commit, ARegularFileIsReplacedAtomically) {
  const fs::path dir = testing::fresh_output_dir("output_layer_replace");
  write_bytes(dir / "a.txt", "old");
  write_text_atomic((dir / "a.txt").string(), "new text");
  EXPECT_EQ(read_all(dir / "a.txt"), "new text");
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  EXPECT_EQ(n, 1);
}

TEST(CheckedWrites, AFullDeviceIsReportedByItsCause) {
  const int fd = ::open("/dev/full", O_WRONLY | O_CLOEXEC);
  if (fd < 0) GTEST_SKIP() << "no /dev/full on this machine";
  const std::string text(10000, 'x');
  try {
    write_all(fd, text.data(), text.size(), "out/table.csv");
    ADD_FAILURE() << "a write to /dev/full succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "out/table.csv: No space left on device");
  }
  ::close(fd);
}

// An HDF5 file whose write fails on a full device: close() names the file and the cause, and
// afterwards no HDF5 file object is open in the process (one left open made the library's
// shutdown at exit() crash). The full device is a character node like /dev/full made in the
// test's own directory (root only): the failure path must not remove it either.
TEST(CheckedWrites, AnHdf5FileThatCannotBeWrittenReleasesEverything) {
  const fs::path dir = testing::fresh_output_dir("output_layer_h5_full");
  const fs::path node = dir / "full";
  if (mknod(node.c_str(), S_IFCHR | 0666, makedev(1, 7)) != 0)
    GTEST_SKIP() << "mknod needs root (" << std::strerror(errno) << ")";
  {
    H5File f = H5File::create(node.string(), "out/shape.h5");
    std::vector<double> x(30000, 1.5);
    f.write("/mesh/positions_um", x.data(), 10000, 3);
    f.write_attribute("force_pN", 16.0);
    try {
      f.close();
      ADD_FAILURE() << "closing onto a full device succeeded";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "out/shape.h5: No space left on device");
    }
  }
  EXPECT_EQ(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL), 0);
  struct stat st {};
  ASSERT_EQ(lstat(node.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

TEST(CheckedWrites, AnHdf5FileRoundTripsThroughTheCheckedWriter) {
  const fs::path dir = testing::fresh_output_dir("output_layer_h5_roundtrip");
  const std::string path = (dir / "a.h5").string();
  {
    TempFile tmp(path);
    H5File f = H5File::create(tmp.path(), path);
    const double v[6] = {1, 2, 3, 4, 5, 6};
    f.write("/g/v", v, 2, 3);
    f.write_attribute("force_pN", 16.0);
    f.close();
    tmp.commit();
  }
  const H5File r = H5File::open_read(path);
  std::vector<double> out;
  EXPECT_EQ(r.read("/g/v", out), (std::pair<hsize_t, hsize_t>{2, 3}));
  EXPECT_EQ(out, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(r.read_attribute_double("force_pN"), 16.0);
}

// Every file H5File writes is sealed (the hash and length of its bytes in a 512-byte HDF5 user
// block): a change of any one byte, anywhere, is refused before HDF5 parses the file; a file
// without a seal (written by another HDF5 program) reads as it is unless a seal is required.
TEST(CheckedWrites, ASealedFileRefusesAnyChangedByteAndAnUnsealedOneIsReadOnlyIfAllowed) {
  const fs::path dir = testing::fresh_output_dir("output_layer_h5_seal");
  const std::string path = (dir / "sealed.h5").string();
  {
    H5File f = H5File::create(path);
    const double v[4] = {1, 2, 3, 4};
    f.write("/g/v", v, 2, 2);
    f.write_attribute("label", std::string("sealed"));
    f.close();
  }
  const std::string intact = read_all(path);
  ASSERT_GT(intact.size(), 512u);
  EXPECT_EQ(intact.compare(0, 21, "rbc sealed HDF5 file\n"), 0);
  EXPECT_EQ(H5File::open_read(path, H5Seal::required).read_attribute_string("label"), "sealed");

  const std::string changed = (dir / "changed.h5").string();
  std::mt19937 rng(5);
  // Bytes of the seal line, of the padding and of the HDF5 image after the block.
  std::vector<std::size_t> at = {21, 30, 50, 511, 512, 513, intact.size() - 1};
  for (int k = 0; k < 40; ++k) at.push_back(512 + rng() % (intact.size() - 512));
  int refused = 0;
  for (const std::size_t i : at) {
    std::string bytes = intact;
    bytes[i] = static_cast<char>(bytes[i] ^ (1 + rng() % 255));
    write_bytes(changed, bytes);
    try {
      const H5File r = H5File::open_read(changed, H5Seal::required);
      // A change in the block's zero padding after the seal line is the one harmless place.
      EXPECT_GT(i, 100u) << "byte " << i;
      EXPECT_LT(i, 512u) << "byte " << i;
    } catch (const std::runtime_error& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(changed), std::string::npos) << e.what();
    }
  }
  EXPECT_GE(refused, static_cast<int>(at.size()) - 1);
  write_bytes(changed, intact.substr(0, intact.size() - 8));  // truncated
  EXPECT_THROW(H5File::open_read(changed), std::runtime_error);

  // A file of another HDF5 writer: no user block, no seal.
  const std::string plain = (dir / "plain.h5").string();
  const hid_t id = H5Fcreate(plain.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(id, 0);
  ASSERT_GE(H5Fclose(id), 0);
  EXPECT_NO_THROW(H5File::open_read(plain));
  try {
    H5File::open_read(plain, H5Seal::required);
    ADD_FAILURE() << "an unsealed file was accepted where a seal is required";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has no seal"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rbc
