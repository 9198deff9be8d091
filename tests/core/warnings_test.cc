// Warning codes (core/warnings.h): unique names, "code: message" form, and docs/cli.md's table
// lists exactly the codes the program can give.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "core/warnings.h"

namespace matfit {
namespace {

TEST(Warnings, NamesAreUniqueAndFormatted) {
  std::set<std::string> names;
  for (const auto& w : AllWarnings()) {
    EXPECT_TRUE(names.insert(w.name).second) << "duplicate warning code " << w.name;
    EXPECT_TRUE(std::regex_match(std::string(w.name), std::regex("[a-z0-9]+(-[a-z0-9]+)*")))
        << w.name;
    const std::string src = w.source;
    EXPECT_TRUE(src == "dataset" || src == "fit" || src == "leaf") << w.name << ": " << src;
    EXPECT_GT(std::string(w.meaning).size(), 10u) << w.name;
    EXPECT_EQ(WarningName(w.code), std::string(w.name));
  }
  EXPECT_EQ(Warning(WarningCode::kAzimuthGap, "gap of 262°"), "azimuth-gap: gap of 262°");
}

TEST(Warnings, DocsListEveryCode) {
  std::ifstream in(std::string(MATFIT_SOURCE_DIR) + "/docs/cli.md");
  ASSERT_TRUE(in) << "docs/cli.md not found under " << MATFIT_SOURCE_DIR;
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  // Table rows "| `code` | source | meaning |" after the "## Warnings and errors" heading.
  const size_t at = doc.find("## Warnings and errors");
  ASSERT_NE(at, std::string::npos) << "docs/cli.md has no '## Warnings and errors' section";
  std::set<std::pair<std::string, std::string>> documented, code;
  const std::regex row(R"(\n\| `([a-z0-9-]+)` \| (dataset|fit|leaf) \|)");
  const std::string section = doc.substr(at);
  for (std::sregex_iterator it(section.begin(), section.end(), row), end; it != end; ++it)
    documented.insert({(*it)[1].str(), (*it)[2].str()});
  for (const auto& w : AllWarnings()) code.insert({w.name, w.source});
  for (const auto& c : code)
    EXPECT_TRUE(documented.count(c))
        << "docs/cli.md lacks warning '" << c.first << "' (" << c.second << ")";
  for (const auto& d : documented)
    EXPECT_TRUE(code.count(d)) << "docs/cli.md lists '" << d.first << "', which matfit never gives";
}

}  // namespace
}  // namespace matfit
