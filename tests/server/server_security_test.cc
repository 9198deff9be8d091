// The service under hostile or broken clients: archives and bodies that must be refused (status
// and a clean data folder), files outside the dataset, bearer tokens, stalled and interrupted
// clients, request smuggling through unread bodies, concurrent deletes.
#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

TEST_F(ServerTest, HostileAndMalformedInputsGetTheRightStatusAndLeaveTheDataFolderClean) {
  opts_.allow_roots = {(tmp_ / "allowed").string()};
  fs::create_directories(tmp_ / "allowed");
  opts_.archive.max_unpacked_bytes = int64_t(16) << 20;
  opts_.archive.max_entries = 100;
  opts_.max_upload_bytes = int64_t(4) << 20;
  Start();
  auto make = [&](const std::string& name, ArchiveWriter::Format f,
                  const std::function<void(ArchiveWriter&)>& add) {
    const std::string p = (tmp_ / name).string();
    ArchiveWriter w(p, f);
    add(w);
    return p;
  };
  struct Case {
    std::string what, archive;
    std::vector<std::pair<std::string, std::string>> fields;
    int status;
    std::string field, message;
  };
  using F = ArchiveWriter::Format;
  const std::string plastic = ZipFixture("plastic-ring12");
  std::vector<Case> cases = {
      {"traversal",
       make("t.zip", F::kZip, [](ArchiveWriter& w) { w.File("../../evil.txt", "x"); }),
       {},
       400,
       "file",
       "'..'"},
      {"absolute",
       make("a.tgz", F::kTarGz, [](ArchiveWriter& w) { w.File("/tmp/evil.txt", "x"); }),
       {},
       400,
       "file",
       "absolute"},
      {"symlink",
       make("s.tar", F::kTar,
            [](ArchiveWriter& w) {
              w.File("set/a.txt", "x");
              w.Symlink("set/evil.txt", "/etc/passwd");
            }),
       {},
       400,
       "file",
       "link"},
      {"zip bomb",
       make("b.zip", F::kZip, [](ArchiveWriter& w) { w.Zeros("set/z.bin", int64_t(64) << 20); }),
       {},
       413,
       "file",
       "unpacks to more than 16 MiB"},
      {"entry count",
       make("n.tar", F::kTarGz,
            [](ArchiveWriter& w) {
              for (int i = 0; i < 150; ++i) w.File("set/f" + std::to_string(i), "x");
            }),
       {},
       413,
       "file",
       "more than 100 entries"},
      {"too large",
       make("big.tar", F::kTar,
            [](ArchiveWriter& w) {
              std::string noise(6 << 20, '\0');
              for (size_t i = 0; i < noise.size(); ++i) noise[i] = char((i * 2654435761u) >> 13);
              w.File("set/noise.bin", noise);
            }),
       {},
       413,
       "",
       "larger than"},
      {"not an archive", (tmp_ / "junk.zip").string(), {}, 400, "file", "not a .zip"},
      {"unknown layout",
       make("u.zip", F::kZip, [](ArchiveWriter& w) { w.File("set/readme.txt", "hi"); }),
       {},
       422,
       "file",
       ""},
      {"not a leaf scan", plastic, {{"mode", "leaf"}}, 422, "file", "not a leaf scan"},
      {"unknown field", plastic, {{"colour", "red"}}, 400, "colour", "not an option"},
      {"bad model", plastic, {{"model", "phong9"}}, 400, "model", "not a model"},
      {"budget without auto", plastic, {{"budget", "0.02"}}, 400, "budget", "model=auto only"},
      {"bad budget", plastic, {{"model", "auto"}, {"budget", "-1"}}, 400, "budget", "positive"},
      {"bad holdout", plastic, {{"holdout", "1"}}, 400, "holdout", "fold count"},
      {"bad view", plastic, {{"view", "north"}}, 400, "view", "THETA,PHI"},
      {"bad mode", plastic, {{"mode", "bake"}}, 400, "mode", "fit or leaf"},
      {"no file", "", {{"model", "lambert"}}, 400, "file", "required"},
  };
  std::ofstream(tmp_ / "junk.zip") << "definitely not an archive";
  for (const auto& c : cases) {
    auto r = Upload(c.archive, c.fields);
    ASSERT_TRUE(r) << c.what << ": no response (" << httplib::to_string(r.error()) << ")";
    EXPECT_EQ(r->status, c.status) << c.what << ": " << r->body;
    const json e = json::parse(r->body, nullptr, false);
    ASSERT_TRUE(e.contains("error")) << c.what << ": " << r->body;
    if (!c.field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), c.field) << c.what;
    }
    EXPECT_NE(e["error"]["message"].get<std::string>().find(c.message), std::string::npos)
        << c.what << ": " << e["error"]["message"];
    ExpectDataClean(0);
  }
  // JSON bodies.
  struct JsonCase {
    std::string what, body;
    int status;
    std::string field, message;
  };
  const std::string outside = kFixtures + "/plastic-ring12";
  const std::vector<JsonCase> jcases = {
      {"malformed", "{\"dataset\": ", 400, "", "not valid JSON"},
      {"not an object", "[1, 2]", 400, "", "JSON object"},
      {"no dataset", "{}", 400, "dataset", "required"},
      {"outside the roots", json{{"dataset", outside}}.dump(), 403, "dataset", "not inside"},
      {"dotdot out of a root",
       json{{"dataset", (tmp_ / "allowed" / ".." / "data").string()}}.dump(), 403, "dataset",
       "not inside"},
      {"missing", json{{"dataset", (tmp_ / "allowed" / "nope").string()}}.dump(), 404, "dataset",
       "does not exist"},
      {"holdout type", json{{"dataset", outside}, {"holdout", "four"}}.dump(), 400, "holdout",
       "integer"},
  };
  for (const auto& c : jcases) {
    auto r = client_->Post("/api/v1/jobs", c.body, "application/json");
    ASSERT_TRUE(r) << c.what;
    EXPECT_EQ(r->status, c.status) << c.what << ": " << r->body;
    const json e = json::parse(r->body, nullptr, false);
    if (!c.field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), c.field) << c.what;
    }
    EXPECT_NE(e["error"]["message"].get<std::string>().find(c.message), std::string::npos)
        << c.what << ": " << r->body;
  }
  auto wrong_type = client_->Post("/api/v1/jobs", "dataset=x", "text/plain");
  ASSERT_TRUE(wrong_type);
  EXPECT_EQ(wrong_type->status, 415);
  ExpectDataClean(0);
  Get("/api/v1/jobs/0123456789abcdef", 404);
  Get("/api/v1/jobs?state=sleeping", 400);
  Get("/api/v1/nothing-here", 404);
}

TEST_F(ServerTest, AbsoluteLpPathsReadOnlyTheUploadsOwnFiles) {
  Start();
  // An .lp file naming existing images outside the upload by absolute path. The server never
  // opens them: a file of the same name in the upload is read instead (as for an .lp written on
  // another machine, with a note); one that is not there fails the submission, and the message
  // shows no server path.
  const std::string p1 = (tmp_ / "lp.zip").string(), p2 = (tmp_ / "lp2.zip").string();
  const std::string fixture = fs::absolute(kFixtures + "/plastic-ring12").string();
  {
    ArchiveWriter w(p1, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "lights.lp");
    std::string lp = Slurp(kFixtures + "/plastic-ring12/lights.lp");
    lp.replace(lp.find("img_000.png"), 11, fixture + "/img_000.png");
    w.File("set/lights.lp", lp);
  }
  const std::string leaf_image = fs::absolute(kFixtures + "/leaf-scan/1_BL.png").string();
  {
    ArchiveWriter w(p2, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "lights.lp");
    std::string lp = Slurp(kFixtures + "/plastic-ring12/lights.lp");
    lp.replace(lp.find("img_001.png"), 11, leaf_image);  // no 1_BL.png in the upload
    w.File("set/lights.lp", lp);
  }
  auto r = Upload(p1, {{"mode", "fit"}, {"model", "lambert"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json j = WaitFor(json::parse(r->body)["id"], Finished);
  ASSERT_EQ(j["state"], "succeeded") << j.dump();
  EXPECT_NE(j["summary"]["warnings"].dump().find("lp-path-fallback"), std::string::npos)
      << j.dump();
  auto r2 = Upload(p2, {{"mode", "fit"}, {"model", "lambert"}});
  ASSERT_TRUE(r2);
  ASSERT_EQ(r2->status, 422) << r2->body;
  const std::string error = json::parse(r2->body)["error"]["message"].get<std::string>();
  EXPECT_NE(error.find("image '" + leaf_image + "' not found nor as '1_BL.png'"), std::string::npos)
      << error;
  EXPECT_EQ(error.find(tmp_.string()), std::string::npos) << error;
}

TEST_F(ServerTest, FilesNamedOutsideTheDatasetFailTheJobWithTheReason) {
  Start();
  // A leaf manifest naming an image by a path above the scan: readable, refused.
  const std::string p2 = (tmp_ / "leaf.zip").string();
  {
    ArchiveWriter w(p2, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/leaf-scan", "scan", "leaf.json");
    std::string manifest = Slurp(kFixtures + "/leaf-scan/leaf.json");
    const std::string outside = fs::absolute(kFixtures + "/leaf-scan/1_BL.png").string();
    manifest.replace(manifest.find("\"*_BL.png\""), 10, "[\"1_BL.png\", \"" + outside + "\"]");
    w.File("scan/leaf.json", manifest);
  }
  const std::pair<std::string, std::string> modes[] = {{p2, "leaf"}};
  for (const auto& [archive, mode] : modes) {
    auto r = Upload(archive, {{"mode", mode}});
    ASSERT_TRUE(r);
    // The submission check reads what the job would (files and headers): refused there (422),
    // or, should a file change after it, when the job runs.
    std::string error;
    if (r->status == 202) {
      const json j = WaitFor(json::parse(r->body)["id"], Finished);
      EXPECT_EQ(j["state"], "failed") << mode;
      error = j["error"].get<std::string>();
    } else {
      EXPECT_EQ(r->status, 422) << mode << ": " << r->body;
      error = json::parse(r->body)["error"]["message"].get<std::string>();
    }
    EXPECT_NE(error.find("outside the dataset folder"), std::string::npos) << mode << ": " << error;
  }
}

TEST_F(ServerTest, BearerTokensGuardWritesAndReads) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\nread-token-0123456789 read\n";
  opts_.token_file = tokens;
  Start();
  const std::string plastic = ZipFixture("plastic-ring12");
  auto none = Upload(plastic, {});
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  EXPECT_EQ(none->get_header_value("WWW-Authenticate"), "Bearer");
  EXPECT_NE(json::parse(none->body)["error"]["message"].get<std::string>().find("Bearer"),
            std::string::npos);
  auto wrong = Upload(plastic, {}, "write-token-0123456788");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  auto reader = Upload(plastic, {}, "read-token-0123456789");
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader->status, 403);
  EXPECT_TRUE(json::parse(reader->body).contains("error"));
  auto ok = Upload(plastic, {}, "write-token-0123456789");
  ASSERT_TRUE(ok);
  ASSERT_EQ(ok->status, 202);
  const std::string id = json::parse(ok->body)["id"];
  auto anon = client_->Get(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(anon);
  EXPECT_EQ(anon->status, 401) << "reads need a token without --public-read";
  auto del = client_->Delete(("/api/v1/jobs/" + id).c_str(), Auth("read-token-0123456789"));
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 403);
  auto read = client_->Get(("/api/v1/jobs/" + id).c_str(), Auth("read-token-0123456789"));
  ASSERT_TRUE(read);
  EXPECT_EQ(read->status, 200);
  auto query = client_->Get(("/api/v1/jobs/" + id + "?token=read-token-0123456789").c_str());
  ASSERT_TRUE(query);
  EXPECT_EQ(query->status, 200) << "?token= works for reads (browser pages)";
  EXPECT_EQ(client_->Get("/healthz")->status, 200);
  EXPECT_EQ(client_->Get("/metrics")->status, 200);
}

TEST_F(ServerTest, PublicReadAndNoTokenFileOnlyOnLoopback) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\n";
  opts_.token_file = tokens;
  opts_.public_read = true;
  Start();
  EXPECT_EQ(client_->Get("/api/v1/jobs")->status, 200);
  EXPECT_EQ(Upload(ZipFixture("plastic-ring12"), {})->status, 401);
  ServerOptions open = opts_;
  open.token_file.clear();
  open.bind = "0.0.0.0";
  std::string why;
  EXPECT_FALSE(open.Check(&why));
  EXPECT_NE(why.find("--token-file"), std::string::npos) << why;
}

TEST_F(ServerTest, StalledClientsTimeOutAndAnInterruptedUploadLeavesNothing) {
  opts_.request_timeout_s = 1;
  opts_.header_timeout_s = 1;
  Start();
  // A client that sends half a request head and stalls is disconnected at the header deadline.
  const int stall = Connect(server_->port());
  ASSERT_GE(stall, 0);
  const std::string half = "GET /healthz HTTP/1.1\r\nHost: x\r\n";
  ASSERT_EQ(::send(stall, half.data(), half.size(), 0), ssize_t(half.size()));
  timeval tv{15, 0};
  ::setsockopt(stall, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string reply;
  char buf[4096];
  const auto t0 = std::chrono::steady_clock::now();
  for (ssize_t n; (n = ::recv(stall, buf, sizeof buf, 0)) > 0;) reply.append(buf, size_t(n));
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Either a bare close or an error status, then a close — never a 200 for half a request.
  EXPECT_EQ(reply.find("200 OK"), std::string::npos) << reply;
  EXPECT_LT(waited, 10) << "no request timeout";
  std::printf("stalled client: closed after %.2f s, reply: %s\n", waited,
              reply.substr(0, reply.find('\r')).c_str());
  ::close(stall);

  // An upload that announces 8 MiB, sends 1 MiB of the file part and hangs up.
  const int up = Connect(server_->port());
  ASSERT_GE(up, 0);
  const std::string part =
      "--b0undary\r\nContent-Disposition: form-data; name=\"file\"; filename=\"x.zip\"\r\n"
      "Content-Type: application/zip\r\n\r\n";
  const std::string head =
      "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: "
      "multipart/form-data; boundary=b0undary\r\nContent-Length: " +
      std::to_string(8 << 20) + "\r\n\r\n" + part;
  ASSERT_EQ(::send(up, head.data(), head.size(), 0), ssize_t(head.size()));
  const std::string chunk(1 << 20, 'z');
  ASSERT_EQ(::send(up, chunk.data(), chunk.size(), 0), ssize_t(chunk.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ::close(up);
  const fs::path uploads = fs::path(opts_.data_dir) / "uploads";
  for (int i = 0; i < 100 && !fs::is_empty(uploads); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_TRUE(fs::is_empty(uploads)) << "the partial upload was left behind";
  EXPECT_TRUE(Get("/api/v1/jobs")["jobs"].empty());
}

TEST_F(ServerTest, ARejectedBodyIsNeverParsedAsTheNextRequest) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\n";
  opts_.token_file = tokens;
  Start();
  const std::string smuggled = "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n";
  auto post = [&](const std::string& auth, const std::string& body, bool chunked) {
    std::string h = "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\n" + auth +
                    "Content-Type: multipart/form-data; boundary=bb\r\n";
    if (!chunked) return h + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
    char size[32];
    std::snprintf(size, sizeof size, "%zx", body.size());
    return h + "Transfer-Encoding: chunked\r\n\r\n" + size + "\r\n" + body + "\r\n0\r\n\r\n";
  };
  auto field = [](const std::string& name, const std::string& v) {
    return "--bb\r\nContent-Disposition: form-data; name=\"" + name + "\"\r\n\r\n" + v + "\r\n";
  };
  // 401 before the body is read: the reply closes the connection.
  std::string r =
      RawExchange(server_->port(), post("", field("model", "lambert") + smuggled, false));
  EXPECT_NE(r.find("401"), std::string::npos) << r;
  EXPECT_EQ(CountResponses(r), 1) << "the unread body was parsed as a request:\n" << r;
  // A repeated field stops the upload early; the rest of the body is never a request.
  const std::string auth = "Authorization: Bearer write-token-0123456789\r\n";
  std::string body = field("model", "lambert") + field("model", "mean") + smuggled + "--bb--\r\n";
  r = RawExchange(server_->port(), post(auth, body, false));
  EXPECT_NE(r.find("400"), std::string::npos) << r;
  EXPECT_EQ(CountResponses(r), 1) << r;
  // Chunked, with many unknown fields: refused at the first one, not after reading them all.
  body.clear();
  for (int i = 0; i < 2000; ++i) body += field("f" + std::to_string(i), std::string(1000, 'x'));
  r = RawExchange(server_->port(), post(auth, body + "--bb--\r\n", true));
  EXPECT_NE(r.find("not an option"), std::string::npos) << r.substr(0, 300);
  EXPECT_EQ(CountResponses(r), 1);
  EXPECT_TRUE(fs::is_empty(fs::path(opts_.data_dir) / "uploads"));
}

TEST_F(ServerTest, ConcurrentDeletesDeleteOnceAndNeverFail) {
  Start();
  for (int round = 0; round < 5; ++round) {
    auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "mean"}});
    ASSERT_TRUE(r);
    const std::string id = json::parse(r->body)["id"];
    ASSERT_EQ(WaitFor(id, Finished)["state"], "succeeded");
    std::atomic<int> deleted{0}, missing{0}, other{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        httplib::Client c("127.0.0.1", server_->port());
        auto d = c.Delete(("/api/v1/jobs/" + id).c_str());
        if (d && d->status == 204)
          deleted++;
        else if (d && d->status == 404)
          missing++;
        else
          other++;
      });
    for (auto& t : threads) t.join();
    EXPECT_EQ(deleted, 1);
    EXPECT_EQ(missing, 3);
    EXPECT_EQ(other, 0);
  }
}

}  // namespace
}  // namespace matfit::server::testing_fixture
