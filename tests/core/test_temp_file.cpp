// SPDX-License-Identifier: GPL-3.0-or-later
// The atomic writers' temporary files (core/io.hpp): a temporary that is not committed is
// removed on unwinding (exceptions, cancelled runs), a committed one replaces its target, and
// the registry a signal handler empties lists exactly the live ones.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "core/h5file.hpp"
#include "core/io.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;

fs::path fresh(const std::string& name) {
  const fs::path dir = fs::path(RBC_BINARY_DIR) / "test_output" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

int files_in(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

void touch(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
}

TEST(TempFile, UncommittedTemporaryIsRemovedWhenAnExceptionUnwinds) {
  const fs::path dir = fresh("temp_file_unwind");
  const std::string target = (dir / "result.csv").string();
  const int live_before = live_temporary_count();
  EXPECT_THROW(
      {
        TempFile tmp(target);
        touch(tmp.path(), "half a file");
        ASSERT_TRUE(fs::exists(tmp.path()));
        EXPECT_EQ(live_temporary_count(), live_before + 1);
        throw std::runtime_error("the writer failed");
      },
      std::runtime_error);
  EXPECT_EQ(files_in(dir), 0);
  EXPECT_EQ(live_temporary_count(), live_before);
}

TEST(TempFile, CommitReplacesTheTargetAndLeavesNoTemporary) {
  const fs::path dir = fresh("temp_file_commit");
  const std::string target = (dir / "result.csv").string();
  touch(target, "old");
  {
    TempFile tmp(target);
    touch(tmp.path(), "new");
    tmp.commit();
    EXPECT_FALSE(fs::exists(tmp.path()));
  }
  std::ifstream in(target);
  std::string text;
  in >> text;
  EXPECT_EQ(text, "new");
  EXPECT_EQ(files_in(dir), 1);
}

TEST(TempFile, RegistryRemovesLiveTemporariesAsASignalHandlerWould) {
  const fs::path dir = fresh("temp_file_registry");
  TempFile a((dir / "a.h5").string()), b((dir / "b.h5").string());
  touch(a.path(), "a");
  touch(b.path(), "b");
  TempFile committed((dir / "c.txt").string());
  touch(committed.path(), "c");
  committed.commit();
  remove_live_temporaries();  // what the second-signal path of the CLI calls before _exit
  EXPECT_FALSE(fs::exists(a.path()));
  EXPECT_FALSE(fs::exists(b.path()));
  EXPECT_TRUE(fs::exists(dir / "c.txt"));  // a finished file is never touched
  EXPECT_EQ(files_in(dir), 1);
}

TEST(TempFile, FailedMeshSnapshotLeavesNothingAndNamesTheUsersFile) {
  const fs::path dir = fresh("temp_file_snapshot");
  MeshSnapshot s;
  s.x = Positions::Zero(3, 3);
  s.faces = Faces(3, 1);
  s.faces << 0, 1, 2;
  // Two fields of one name: HDF5 refuses the second dataset mid-file.
  s.vertex_fields = {{"u", Eigen::VectorXd::Zero(3)}, {"u", Eigen::VectorXd::Zero(3)}};
  const std::string base = (dir / "shape").string();
  try {
    write_mesh_snapshot(base, s);
    FAIL() << "a duplicate dataset was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(base + ".h5"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find(".partial"), std::string::npos) << e.what();
  }
  EXPECT_EQ(files_in(dir), 0);
}

}  // namespace
}  // namespace rbc
