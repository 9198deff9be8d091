// Issue 22 ("Service hardening"), the service's inputs, against a real server on loopback:
// - datasets named by path (--allow-root) whose files are links leading out of the folder, for
//   every kind of file a reader opens (finding 2);
// - decompression bombs: tiny PNGs declaring huge images, refused from their headers before the
//   202; `matfit info` names the file instead of printing std::bad_alloc (finding 6);
// - archives: an unpack budget relative to the upload, many empty folders, `tar -C dir .`
//   output, a disk that fills while unpacking (finding 9).
#include <sys/mount.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>

#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

// ---- PNG files written byte by byte (the header can then say what a test needs) ----

void PutBe32(std::string* s, uint32_t v) {
  for (int k = 3; k >= 0; --k) s->push_back(char((v >> (8 * k)) & 0xFF));
}

std::string PngChunk(const char* type, const std::string& data) {
  std::string c;
  PutBe32(&c, uint32_t(data.size()));
  const std::string body = std::string(type, 4) + data;
  c += body;
  PutBe32(&c, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
  return c;
}

// A grey PNG whose header declares w×h at `bits` (1 or 8) per sample. complete: every row is
// there (zeros, deflated ~1000:1: an honest decompression bomb); otherwise the data holds one
// row only, so the header lies about the file.
std::string GreyPng(uint32_t w, uint32_t h, int bits, bool complete) {
  std::string ihdr;
  PutBe32(&ihdr, w);
  PutBe32(&ihdr, h);
  ihdr += char(bits), ihdr += char(0), ihdr += char(0), ihdr += char(0), ihdr += char(0);
  const std::string row(1 + (size_t(w) * bits + 7) / 8, '\0');  // filter byte + samples
  z_stream z{};
  deflateInit(&z, 9);
  std::string idat;
  std::vector<unsigned char> out(1 << 16);
  const uint32_t rows = complete ? h : 1;
  for (uint32_t y = 0; y < rows; ++y) {
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(row.data()));
    z.avail_in = uInt(row.size());
    const int flush = y + 1 == rows ? Z_FINISH : Z_NO_FLUSH;
    do {
      z.next_out = out.data();
      z.avail_out = uInt(out.size());
      deflate(&z, flush);
      idat.append(reinterpret_cast<char*>(out.data()), out.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  return std::string("\x89PNG\r\n\x1a\n", 8) + PngChunk("IHDR", ihdr) + PngChunk("IDAT", idat) +
         PngChunk("IEND", "");
}

// An .lp dataset of n copies of `png` (b_00.png ...) with frontal-ish lights.
void WriteLpDataset(const fs::path& dir, int n, const std::string& png) {
  fs::create_directories(dir);
  std::string lp = std::to_string(n) + "\n";
  for (int i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "b_%02d.png", i);
    std::ofstream(dir / name, std::ios::binary) << png;
    lp += std::string(name) + " " + std::to_string(0.1 * (i % 4)) + " " +
          std::to_string(0.1 * (i / 4)) + " 1\n";
  }
  std::ofstream(dir / "lights.lp") << lp;
}

std::string Shell(const std::string& command) {  // stdout + stderr of a shell command
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  ::pclose(p);
  return out;
}

// A .tar.gz of `n` empty folders and nothing else, 100 to a parent folder.
void WriteFolderArchive(const std::string& path, int n) {
  struct archive* a = archive_write_new();
  archive_write_set_format_pax_restricted(a);
  archive_write_add_filter_gzip(a);
  archive_write_open_filename(a, path.c_str());
  for (int i = 0; i < n; ++i) {
    archive_entry* e = archive_entry_new();
    const std::string name = "set/" + std::to_string(i / 100) + "/" + std::to_string(i) + "/";
    archive_entry_set_pathname(e, name.c_str());
    archive_entry_set_filetype(e, AE_IFDIR);
    archive_entry_set_perm(e, 0755);
    archive_write_header(a, e);
    archive_entry_free(e);
  }
  archive_write_close(a);
  archive_write_free(a);
}

std::string Message(const httplib::Result& r) {
  const json e = json::parse(r->body, nullptr, false);
  return e.contains("error") ? e["error"].value("message", "") : std::string();
}

using HardeningInputTest = ServerTest;

// ---- finding 2: --allow-root datasets whose files are links out of the folder ----

TEST_F(HardeningInputTest, LinksOutOfADatasetNamedByPathAreRefusedForEveryKindOfFile) {
  const fs::path allowed = tmp_ / "allowed", elsewhere = tmp_ / "elsewhere";
  opts_.allow_roots = {allowed.string()};
  fs::create_directories(allowed);
  fs::create_directories(elsewhere);
  // What a link may lead to: a text file whose first line is a secret (a reader that echoes the
  // line it could not parse would show it), a valid image, a valid EXR, a folder of BTF images.
  const std::string secret = "SECRET-4f1c-do-not-show";
  std::ofstream(elsewhere / "secret.txt") << secret << "\n0 0 1\n";
  fs::copy_file(kFixtures + "/plastic-ring12/img_000.png", elsewhere / "secret.png");
  fs::copy_file(kFixtures + "/plastic-ring12/truth/normal.exr", elsewhere / "normal.exr");
  fs::copy(kFixtures + "/plaster-bonn81/tv000_pv000", elsewhere / "view",
           fs::copy_options::recursive);
  // Generated layouts that have no fixture: DiLiGenT and lights.txt.
  const fs::path gen = tmp_ / "gen";
  for (Layout l : {Layout::kDiligent, Layout::kLightsTxt}) {
    synth::SynthOptions so;
    so.material = "plastic", so.lights = "ring12", so.size = 16, so.layout = l;
    auto r = synth::Synthesize(so);
    ASSERT_TRUE(r.ok()) << r.status().message();
    ASSERT_TRUE(
        synth::WriteSynthDataset(*r, so, (gen / LayoutName(l) / "obj").string(), true).ok());
  }
  const std::string diligent = (gen / "diligent" / "obj").string();
  const std::string lights_txt = (gen / "lights-txt" / "obj").string();
  struct Case {
    std::string what, source, link, target, mode = "fit";
  };
  const std::string plastic = kFixtures + "/plastic-ring12", leaf = kFixtures + "/leaf-scan";
  const std::string txt = (elsewhere / "secret.txt").string();
  const std::string png = (elsewhere / "secret.png").string();
  const std::vector<Case> cases = {
      {".lp light file", plastic, "lights.lp", txt},
      {".lp image", plastic, "img_003.png", png},
      {".lp mask", plastic, "mask.png", png},
      {"lights.txt", lights_txt, "lights.txt", txt},
      {"lights.txt image", lights_txt, "obj.2.png", png},
      {"lights.txt mask", lights_txt, "obj.mask.png", png},
      {"DiLiGenT filenames.txt", diligent, "filenames.txt", txt},
      {"DiLiGenT light_directions.txt", diligent, "light_directions.txt", txt},
      {"DiLiGenT light_intensities.txt", diligent, "light_intensities.txt", txt},
      {"DiLiGenT image", diligent, "005.png", png},
      {"DiLiGenT mask", diligent, "mask.png", png},
      {"BTF image", kFixtures + "/plaster-bonn81", "tv000_pv000/00003 tl015 pl120 tv000 pv000.png",
       png},
      {"BTF view folder", kFixtures + "/plaster-bonn81", "tv000_pv000",
       (elsewhere / "view").string()},
      {"leaf manifest", leaf, "leaf.json", txt, "leaf"},
      {"leaf top-lit .lp", leaf, "top_lights.lp", txt, "leaf"},
      {"leaf back-lit image", leaf, "2_BL.png", png, "leaf"},
      {"leaf top-lit image", leaf, "3_TL.png", png, "leaf"},
  };
  Start();
  int n = 0;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const fs::path dir = allowed / ("set" + std::to_string(n++)) / fs::path(c.source).filename();
    fs::create_directories(dir.parent_path());
    fs::copy(c.source, dir, fs::copy_options::recursive);
    fs::remove_all(dir / c.link);
    fs::create_symlink(c.target, dir / c.link);
    json body = {{"dataset", dir.string()}};
    if (c.mode == "leaf") body["mode"] = "leaf";
    auto r = SubmitPath(body);
    ASSERT_TRUE(r);
    std::string message;
    if (r->status == 202) {  // refused when the job reads the file
      const json j = WaitFor(json::parse(r->body)["id"], Finished);
      EXPECT_EQ(j["state"], "failed") << j.dump();
      message = j["error"].is_string() ? j["error"].get<std::string>() : "";
    } else {  // or already at submission
      EXPECT_EQ(r->status, 422) << r->body;
      message = Message(r);
    }
    EXPECT_NE(message.find(c.link), std::string::npos) << "does not name the link: " << message;
    EXPECT_NE(message.find("outside the dataset folder"), std::string::npos) << message;
    EXPECT_EQ(message.find(secret), std::string::npos) << "echoes the outside file: " << message;
    EXPECT_EQ(message.find(elsewhere.string()), std::string::npos)
        << "shows where the link leads: " << message;
  }
}

TEST_F(HardeningInputTest, ALightsTxtInTheParentFolderIsNotReadFromOutsideTheDataset) {
  const fs::path allowed = tmp_ / "allowed";
  opts_.allow_roots = {allowed.string()};
  synth::SynthOptions so;
  so.material = "plastic", so.lights = "ring12", so.size = 16, so.layout = Layout::kLightsTxt;
  auto r = synth::Synthesize(so);
  ASSERT_TRUE(r.ok());
  const fs::path dir = allowed / "psm" / "obj";
  ASSERT_TRUE(synth::WriteSynthDataset(*r, so, dir.string(), true).ok());
  // The UW layout keeps lights.txt beside the object folders; here it holds a secret.
  const std::string secret = "SECRET-parent-lights-9d2e";
  fs::remove(dir / "lights.txt");
  std::ofstream(allowed / "psm" / "lights.txt") << secret << "\n";
  Start();
  auto s = SubmitPath({{"dataset", dir.string()}});
  ASSERT_TRUE(s);
  std::string message;
  if (s->status == 202) {
    const json j = WaitFor(json::parse(s->body)["id"], Finished);
    EXPECT_EQ(j["state"], "failed");
    message = j["error"].is_string() ? j["error"].get<std::string>() : "";
  } else {
    EXPECT_EQ(s->status, 422) << s->body;
    message = Message(s);
  }
  EXPECT_EQ(message.find(secret), std::string::npos) << message;
  EXPECT_NE(message.find("lights.txt"), std::string::npos) << message;
  EXPECT_NE(message.find("parent folder"), std::string::npos) << message;
  EXPECT_NE(message.find("outside the dataset folder"), std::string::npos) << message;
}

TEST_F(HardeningInputTest, ATruthMapLinkedFromOutsideIsNotReadAndTheJobSaysSo) {
  const fs::path allowed = tmp_ / "allowed", elsewhere = tmp_ / "elsewhere";
  opts_.allow_roots = {allowed.string()};
  fs::create_directories(elsewhere);
  fs::copy_file(kFixtures + "/plastic-ring12/truth/normal.exr", elsewhere / "normal.exr");
  const fs::path dir = allowed / "plastic";
  fs::create_directories(allowed);
  fs::copy(kFixtures + "/plastic-ring12", dir, fs::copy_options::recursive);
  fs::remove(dir / "truth" / "normal.exr");
  fs::create_symlink(elsewhere / "normal.exr", dir / "truth" / "normal.exr");
  Start();
  auto s = SubmitPath({{"dataset", dir.string()}, {"model", "lambert"}});
  ASSERT_TRUE(s);
  ASSERT_EQ(s->status, 202) << s->body;
  const json j = WaitFor(json::parse(s->body)["id"], Finished);
  // Truth maps only score a fit: the job succeeds, unscored, and its warnings say why.
  ASSERT_EQ(j["state"], "succeeded") << j.dump();
  EXPECT_FALSE(j["summary"].contains("normal_mae_deg")) << "the outside truth map was read";
  const std::string warnings = j["summary"]["warnings"].dump();
  EXPECT_NE(warnings.find("truth/normal.exr"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("outside the dataset folder"), std::string::npos) << warnings;
  EXPECT_EQ(warnings.find(elsewhere.string()), std::string::npos) << warnings;
}

// ---- finding 6: decompression bombs ----

class BombTest : public ServerTest {
 protected:
  static constexpr uint32_t kSide = 16384;
  static constexpr int kImages = 12;
  // 12 × 16384² grey 1-bit PNGs: ~33 KB each, 3.2 × 10⁹ samples together.
  void MakeBomb(const fs::path& dir, bool complete) {
    WriteLpDataset(dir, kImages, GreyPng(kSide, kSide, 1, complete));
  }
};

TEST_F(BombTest, AStackOverThePixelBudgetIsRefusedFromItsHeadersBeforeThe202) {
  opts_.allow_roots = {(tmp_ / "allowed").string()};
  MakeBomb(tmp_ / "allowed" / "bomb", /*complete=*/true);
  const std::string archive = (tmp_ / "bomb.tgz").string();
  {
    ArchiveWriter w(archive, ArchiveWriter::Format::kTarGz);
    w.Folder((tmp_ / "allowed" / "bomb").string(), "bomb");
  }
  EXPECT_LT(fs::file_size(archive), 1u << 20);  // tiny upload
  Start();
  const std::string total = std::to_string(int64_t(kImages) * kSide * kSide);
  // Uploaded and named by path: both get 422 from the image headers, naming the total.
  auto up = Upload(archive, {});
  ASSERT_TRUE(up);
  EXPECT_EQ(up->status, 422) << up->body;
  EXPECT_NE(Message(up).find(total), std::string::npos) << Message(up);
  EXPECT_NE(Message(up).find("limit"), std::string::npos) << Message(up);
  ExpectDataClean(0);
  auto path = SubmitPath({{"dataset", (tmp_ / "allowed" / "bomb").string()}});
  ASSERT_TRUE(path);
  EXPECT_EQ(path->status, 422) << path->body;
  EXPECT_NE(Message(path).find(total), std::string::npos) << Message(path);
  EXPECT_EQ(Get("/api/v1/jobs")["jobs"].size(), 0u);
}

TEST_F(BombTest, ImagesWhoseHeadersLieAboutTheirSizeAreRefusedAtSubmission) {
  MakeBomb(tmp_ / "bomb", /*complete=*/false);
  const std::string archive = (tmp_ / "lie.zip").string();
  {
    ArchiveWriter w(archive, ArchiveWriter::Format::kZip);
    w.Folder((tmp_ / "bomb").string(), "bomb");
  }
  Start();
  auto up = Upload(archive, {});
  ASSERT_TRUE(up);
  EXPECT_EQ(up->status, 422) << up->body;
  EXPECT_NE(Message(up).find("16384x16384"), std::string::npos) << Message(up);
  EXPECT_NE(Message(up).find("b_0"), std::string::npos) << Message(up);
  ExpectDataClean(0);
}

// The CLI: a header that lies names the file and its declared size; a stack that does not fit
// in memory names its size (run under a 3 GiB address-space limit, like a smaller machine).
TEST_F(BombTest, CliNamesTheFileAndTheDeclaredSizeInsteadOfBadAlloc) {
  MakeBomb(tmp_ / "lie", /*complete=*/false);
  const std::string lie =
      Shell(std::string(MATFIT_BINARY) + " info --quiet " + (tmp_ / "lie").string());
  EXPECT_EQ(lie.find("bad_alloc"), std::string::npos) << lie;
  EXPECT_NE(lie.find("b_00.png"), std::string::npos) << lie;
  EXPECT_NE(lie.find("16384x16384"), std::string::npos) << lie;
  MakeBomb(tmp_ / "honest", /*complete=*/true);
  const std::string fit = " fit --quiet --model lambert --out " + (tmp_ / "pack").string() + " ";
  for (const std::string& cmd : {std::string(" info --quiet "), fit}) {
    const std::string out = Shell("ulimit -v 3000000; " + std::string(MATFIT_BINARY) + cmd +
                                  (tmp_ / "honest").string());
    SCOPED_TRACE(cmd);
    EXPECT_EQ(out.find("bad_alloc"), std::string::npos) << out;
    EXPECT_NE(out.find("16384x16384"), std::string::npos) << out;
    EXPECT_NE(out.find("memory"), std::string::npos) << out;
  }
}

// ---- finding 9: archives ----

TEST_F(HardeningInputTest, TheUnpackBudgetFollowsTheUploadSize) {
  Start();  // default limits
  const std::string archive = (tmp_ / "zeros.zip").string();
  {
    ArchiveWriter w(archive, ArchiveWriter::Format::kZip);
    w.Zeros("set/zeros.bin", int64_t(300) << 20);  // ~300 KB upload
  }
  ASSERT_LT(fs::file_size(archive), 1u << 20);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = Upload(archive, {});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413) << r->body;
  EXPECT_NE(Message(r).find("times the upload"), std::string::npos) << Message(r);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  ExpectDataClean(0);
}

TEST_F(HardeningInputTest, AnArchiveOfManyEmptyFoldersIsRefusedQuickly) {
  Start();  // default limits
  const std::string archive = (tmp_ / "folders.tgz").string();
  WriteFolderArchive(archive, 19000);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = Upload(archive, {});
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413) << r->body;
  EXPECT_NE(Message(r).find("folders"), std::string::npos) << Message(r);
  EXPECT_LT(s, 3.0);  // it took 4 s here (29 s in the issue) to unpack them all
  ExpectDataClean(0);
}

TEST_F(HardeningInputTest, TarOfADotFolderIsAccepted) {
  Start();
  const std::string archive = (tmp_ / "dot.tgz").string();
  // What `tar czf x.tgz -C dir .` writes: "./", "./img_000.png", "./truth/", ...
  const std::string out = Shell("tar czf " + archive + " -C " + kFixtures + "/plastic-ring12 .");
  ASSERT_TRUE(fs::exists(archive)) << out;
  ASSERT_NE(Shell("tar tzf " + archive).find("./img_000.png"), std::string::npos);
  auto r = Upload(archive, {{"model", "lambert"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json j = WaitFor(json::parse(r->body)["id"], Finished);
  EXPECT_EQ(j["state"], "succeeded") << j.dump();
}

TEST_F(HardeningInputTest, AFullDiskWhileUnpackingGives507LeavesNothingAndTheServerGoesOn) {
  fs::create_directories(opts_.data_dir);
  if (::mount("tmpfs", opts_.data_dir.c_str(), "tmpfs", 0, "size=2m") != 0)
    GTEST_SKIP() << "cannot mount a 2 MiB tmpfs on the data folder (" << std::strerror(errno)
                 << "); this test needs root";
  struct Unmount {  // the server first: it holds files on the mount
    std::function<void()> stop;
    std::string dir;
    ~Unmount() {
      stop();
      ::umount2(dir.c_str(), MNT_DETACH);
    }
  } unmount{[this] { client_.reset(), server_.reset(); }, opts_.data_dir};
  Start();
  const std::string archive = (tmp_ / "big.tgz").string();
  {
    ArchiveWriter w(archive, ArchiveWriter::Format::kTarGz);
    w.Zeros("set/a.bin", int64_t(3) << 20);  // 3 MiB on a 2 MiB disk, from a ~3 KB upload
  }
  auto r = Upload(archive, {});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 507) << r->body;
  EXPECT_NE(Message(r).find("space"), std::string::npos) << Message(r);
  ExpectDataClean(0);
  // The space is back: a real dataset goes through, and the API answers.
  const std::string small = (tmp_ / "plastic.zip").string();
  {
    ArchiveWriter w(small, ArchiveWriter::Format::kZip);
    for (int i = 0; i < 12; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "img_%03d.png", i);
      w.File(std::string("set/") + name, Slurp(kFixtures + "/plastic-ring12/" + name));
    }
    w.File("set/lights.lp", Slurp(kFixtures + "/plastic-ring12/lights.lp"));
  }
  auto ok = Upload(small, {{"model", "lambert"}});
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 202) << ok->body;
  EXPECT_EQ(Get("/api/v1/jobs")["jobs"].size(), 1u);
}

}  // namespace
}  // namespace matfit::server::testing_fixture
