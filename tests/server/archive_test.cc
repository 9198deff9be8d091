// Archive extraction: the layouts users upload work; every hostile entry is refused, names the
// entry, and leaves nothing behind.
#include "server/archive.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tests/server/archive_util.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using testing::ArchiveWriter;

class ArchiveTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("matfit_archive_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // Extracts into dir_/out; returns the status, sets problem_.
  Status Extract(const std::string& archive, ArchiveLimits limits = {}) {
    auto r = ExtractArchive(archive, Path("out"), limits, &problem_);
    if (r.ok()) result_ = *r;
    return r.status();
  }
  fs::path dir_;
  ArchiveProblem problem_ = ArchiveProblem::kNone;
  ArchiveResult result_;
};

TEST_F(ArchiveTest, ExtractsZipTarAndTarGzWithTheirTopFolderAsDatasetRoot) {
  for (auto f :
       {ArchiveWriter::Format::kZip, ArchiveWriter::Format::kTar, ArchiveWriter::Format::kTarGz}) {
    const std::string a = Path("a.bin");  // by content, not by name
    {
      ArchiveWriter w(a, f);
      w.File("set/lights.lp", "1\nimg.png 0 0 1\n");
      w.File("set/sub/x.txt", "hello");
      w.File("__MACOSX/set/._lights.lp", "junk");
    }
    ASSERT_TRUE(Extract(a).ok()) << int(f);
    EXPECT_EQ(result_.dataset_root, Path("out") + "/set");
    EXPECT_EQ(result_.bytes, 16 + 5);
    std::ifstream in(Path("out") + "/set/sub/x.txt");
    std::string s;
    in >> s;
    EXPECT_EQ(s, "hello");
    EXPECT_FALSE(fs::exists(Path("out") + "/__MACOSX"));
    fs::remove_all(Path("out"));
    fs::remove(a);
  }
}

TEST_F(ArchiveTest, FlatArchiveIsItsOwnRoot) {
  {
    ArchiveWriter w(Path("a.zip"), ArchiveWriter::Format::kZip);
    w.File("a.txt", "1");
    w.File("b.txt", "2");
  }
  ASSERT_TRUE(Extract(Path("a.zip")).ok());
  EXPECT_EQ(result_.dataset_root, Path("out"));
}

TEST_F(ArchiveTest, RefusesTraversalAbsoluteNamesAndLinksLeavingNothing) {
  struct Case {
    const char* what;
    std::function<void(ArchiveWriter&)> add;
    const char* message;
  };
  const Case cases[] = {
      {"dotdot", [](ArchiveWriter& w) { w.File("../evil.txt", "x"); }, "'..'"},
      {"nested dotdot", [](ArchiveWriter& w) { w.File("a/../../evil.txt", "x"); }, "'..'"},
      {"absolute", [](ArchiveWriter& w) { w.File("/tmp/matfit_evil.txt", "x"); }, "absolute"},
      // libarchive's zip reader turns '\' into '/': then the '..' rule refuses it.
      {"backslash", [](ArchiveWriter& w) { w.File("..\\evil.txt", "x"); }, ""},
      {"symlink", [](ArchiveWriter& w) { w.Symlink("set/link", "/etc"); }, "link"},
      {"hardlink", [](ArchiveWriter& w) { w.Hardlink("set/hard", "/etc/passwd"); }, "link"},
      {"not utf-8", [](ArchiveWriter& w) { w.File("set/p\xff.txt", "x"); }, "not UTF-8"},
      {"file then folder",
       [](ArchiveWriter& w) {
         w.File("set/d", "x");
         w.File("set/d/e.txt", "y");
       },
       "set/d/e.txt"},
  };
  for (const auto& c : cases)
    for (auto f : {ArchiveWriter::Format::kZip, ArchiveWriter::Format::kTarGz}) {
      if (std::string(c.what) == "hardlink" && f == ArchiveWriter::Format::kZip) continue;
      {
        ArchiveWriter w(Path("h.bin"), f);
        w.File("set/ok.txt", "fine");
        c.add(w);
      }
      const Status st = Extract(Path("h.bin"));
      EXPECT_FALSE(st.ok()) << c.what;
      EXPECT_EQ(problem_, ArchiveProblem::kUnsafeEntry) << c.what << ": " << st.message();
      EXPECT_NE(st.message().find(c.message), std::string::npos) << st.message();
      EXPECT_FALSE(fs::exists(Path("out"))) << c.what << ": the half extraction was left";
      EXPECT_FALSE(fs::exists(dir_ / "evil.txt"));
      EXPECT_FALSE(fs::exists("/tmp/matfit_evil.txt"));
    }
}

TEST_F(ArchiveTest, ZipBombStopsAtTheUnpackedLimitCountingWrittenBytes) {
  {
    ArchiveWriter w(Path("bomb.zip"), ArchiveWriter::Format::kZip);
    w.Zeros("set/zeros.bin", int64_t(64) << 20);
  }
  EXPECT_LT(fs::file_size(Path("bomb.zip")), 1u << 20);  // 64 MiB of zeros in < 1 MiB
  ArchiveLimits limits;
  limits.max_unpacked_bytes = int64_t(8) << 20;
  const Status st = Extract(Path("bomb.zip"), limits);
  EXPECT_EQ(problem_, ArchiveProblem::kLimit) << st.message();
  EXPECT_NE(st.message().find("8 MiB"), std::string::npos) << st.message();
  EXPECT_FALSE(fs::exists(Path("out")));
}

TEST_F(ArchiveTest, EntryCountLimit) {
  {
    ArchiveWriter w(Path("many.tar"), ArchiveWriter::Format::kTar);
    for (int i = 0; i < 50; ++i) w.File("set/f" + std::to_string(i), "x");
  }
  ArchiveLimits limits;
  limits.max_entries = 20;
  EXPECT_FALSE(Extract(Path("many.tar"), limits).ok());
  EXPECT_EQ(problem_, ArchiveProblem::kLimit);
  limits.max_entries = 50;
  EXPECT_TRUE(Extract(Path("many.tar"), limits).ok());
}

TEST_F(ArchiveTest, NotAnArchiveAndEmptyArchiveAreMalformed) {
  std::ofstream(Path("x.zip")) << "this is not a zip file at all";
  EXPECT_FALSE(Extract(Path("x.zip")).ok());
  EXPECT_EQ(problem_, ArchiveProblem::kMalformed);
  { ArchiveWriter w(Path("empty.tar"), ArchiveWriter::Format::kTar); }
  const Status st = Extract(Path("empty.tar"));
  EXPECT_FALSE(st.ok());
  EXPECT_EQ(problem_, ArchiveProblem::kMalformed) << st.message();
  EXPECT_FALSE(fs::exists(Path("out")));
}

}  // namespace
}  // namespace matfit::server
