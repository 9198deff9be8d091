// Bearer-token authorisation (the job store: job_store_test.cc).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "server/auth.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

TEST(Auth, ConstantTimeEqualsIsEquality) {
  EXPECT_TRUE(ConstantTimeEquals("abcdef", "abcdef"));
  EXPECT_FALSE(ConstantTimeEquals("abcdef", "abcdeg"));
  EXPECT_FALSE(ConstantTimeEquals("abcdef", "abcde"));
  EXPECT_FALSE(ConstantTimeEquals("", "a"));
  EXPECT_TRUE(ConstantTimeEquals("", ""));
  EXPECT_FALSE(ConstantTimeEquals(std::string_view("ab\0c", 4), std::string_view("ab\0d", 4)));
}

TEST(Auth, TokenFileRolesAndErrorsThatNameTheLine) {
  const std::string f =
      (fs::temp_directory_path() / ("matfit_auth_tokens_" + std::to_string(::getpid()))).string();
  std::ofstream(f) << "# lab tokens\nwritewritewritewrite1\nreadreadreadreadread read  # viewer\n";
  auto t = TokenSet::Load(f);
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_EQ(t->size(), 2u);
  EXPECT_EQ(t->Check("", Access::kRead), AuthResult::kMissing);
  EXPECT_EQ(t->Check("Basic abc", Access::kRead), AuthResult::kMissing);
  EXPECT_EQ(t->Check("Bearer nottherightone123", Access::kRead), AuthResult::kInvalid);
  EXPECT_EQ(t->Check("Bearer writewritewritewrite1", Access::kWrite), AuthResult::kOk);
  EXPECT_EQ(t->Check("Bearer readreadreadreadread", Access::kRead), AuthResult::kOk);
  EXPECT_EQ(t->Check("Bearer readreadreadreadread", Access::kWrite), AuthResult::kForbidden);
  EXPECT_EQ(t->Check("Bearer writewritewritewrite", Access::kWrite), AuthResult::kInvalid);

  std::ofstream(f) << "goodgoodgoodgoodgood\nshort\n";
  auto bad = TokenSet::Load(f);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find(f + ":2"), std::string::npos) << bad.status().message();
  std::ofstream(f) << "goodgoodgoodgoodgood admin\n";
  bad = TokenSet::Load(f);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("role 'admin'"), std::string::npos);
  std::ofstream(f) << "# nothing\n";
  EXPECT_FALSE(TokenSet::Load(f).ok());
  fs::remove(f);
}

// A cluster's database keeps only SHA-256 hashes; a token checks against its hash like a
// plain one, roles included.
TEST(Auth, HashedTokensFromADatabaseCheckLikePlainOnes) {
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  auto a = NewToken(), b = NewToken();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->size(), 43u);
  EXPECT_NE(*a, *b);
  for (const char c : *a)
    EXPECT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_');
  TokenSet set = TokenSet::FromList({{"plainplainplainplain", true}});
  set.AddHashed(Sha256Hex(*a), false);
  EXPECT_EQ(set.Check("Bearer " + *a, Access::kRead), AuthResult::kOk);
  EXPECT_EQ(set.Check("Bearer " + *a, Access::kWrite), AuthResult::kForbidden);
  EXPECT_EQ(set.Check("Bearer " + *b, Access::kRead), AuthResult::kInvalid);
  EXPECT_EQ(set.Check("Bearer " + Sha256Hex(*a), Access::kRead),
            AuthResult::kInvalid);  // not the hash itself
  EXPECT_EQ(set.Check("Bearer plainplainplainplain", Access::kWrite), AuthResult::kOk);
}

}  // namespace
}  // namespace matfit::server
