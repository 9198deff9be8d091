// `matfit tokens add|list|revoke --db URL`: the bearer tokens a cluster keeps in its job
// database (docs/scale-out.md). Only their SHA-256 is stored; `add` prints the new token once.
// Nodes started with --db-tokens accept them and re-read the set every lease/3 seconds.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "server/auth.h"
#include "server/job_store.h"

namespace matfit::app {
namespace {

struct TokensArgs {
  std::string db, role = "write", label, hash;
};

StatusOr<std::unique_ptr<server::JobStore>> OpenStore(const std::string& db) {
  if (!server::IsPostgresUrl(db))
    return InvalidArgument("--db takes the cluster's postgresql://user@host:port/db URL");
  return server::OpenPostgresJobStore(db);
}

int Add(const TokensArgs& a) {
  if (a.role != "write" && a.role != "read") return Fail("tokens", "--role must be write or read");
  auto store = OpenStore(a.db);
  if (!store.ok()) return Fail("tokens", store.status().message().c_str());
  auto token = server::NewToken();
  if (!token.ok()) return Fail("tokens", token.status().message().c_str());
  server::StoredToken t;
  t.sha256_hex = server::Sha256Hex(*token);
  t.write = a.role == "write";
  t.label = a.label;
  t.created = double(std::time(nullptr));
  if (Status st = (*store)->AddToken(t); !st.ok()) return Fail("tokens", st.message().c_str());
  std::printf("%s\n", token->c_str());
  std::fprintf(stderr, "matfit tokens: added a %s token%s (sha256 %.12s…); it is shown only now\n",
               a.role.c_str(), a.label.empty() ? "" : (" '" + a.label + "'").c_str(),
               t.sha256_hex.c_str());
  return 0;
}

int List(const TokensArgs& a) {
  auto store = OpenStore(a.db);
  if (!store.ok()) return Fail("tokens", store.status().message().c_str());
  auto tokens = (*store)->ListTokens();
  if (!tokens.ok()) return Fail("tokens", tokens.status().message().c_str());
  std::printf("%-14s %-6s %-20s %s\n", "sha256", "role", "created (UTC)", "label");
  for (const auto& t : *tokens) {
    char when[32] = "?";
    const std::time_t s = std::time_t(t.created);
    std::tm tm{};
    if (gmtime_r(&s, &tm)) std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", &tm);
    std::printf("%-14.12s %-6s %-20s %s\n", t.sha256_hex.c_str(), t.write ? "write" : "read", when,
                t.label.c_str());
  }
  return 0;
}

int Revoke(const TokensArgs& a) {
  if (a.hash.empty() == a.label.empty())
    return Fail("tokens",
                "name the tokens to revoke: --hash PREFIX (≥ 8 hex digits, from "
                "`matfit tokens list`) or --label LABEL");
  if (!a.hash.empty()) {
    if (a.hash.size() < 8) return Fail("tokens", "--hash needs at least 8 hex digits");
    for (const char c : a.hash)
      if (!std::isxdigit(static_cast<unsigned char>(c)) ||
          std::isupper(static_cast<unsigned char>(c)))
        return Fail("tokens", "--hash takes lowercase hex digits (as `matfit tokens list` shows)");
  }
  auto store = OpenStore(a.db);
  if (!store.ok()) return Fail("tokens", store.status().message().c_str());
  auto n = (*store)->RevokeTokens(a.hash, a.label);
  if (!n.ok()) return Fail("tokens", n.status().message().c_str());
  if (*n == 0) {
    const std::string what = a.hash.empty() ? "label '" + a.label + "'" : "hash prefix " + a.hash;
    return Fail("tokens",
                ("no token has " + what + "; `matfit tokens list --db URL` shows them").c_str());
  }
  std::fprintf(stderr,
               "matfit tokens: revoked %d token%s (nodes stop accepting within lease/3 s)\n", *n,
               *n == 1 ? "" : "s");
  return 0;
}

}  // namespace

void RegisterTokens(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<TokensArgs>();
  CLI::App* sub = app.add_subcommand(
      "tokens", "Bearer tokens kept in a cluster's job database (for serve --db-tokens)");
  sub->require_subcommand(1);
  auto db = [&](CLI::App* c) {
    c->add_option("--db", args->db, "the cluster's job database, postgresql://…")->required();
  };
  CLI::App* add =
      sub->add_subcommand("add", "Create a token; prints it once (only its hash is kept)");
  db(add);
  add->add_option("--role", args->role, "write or read")->capture_default_str();
  add->add_option("--label", args->label, "a name for the token (who or what uses it)");
  add->callback([args, exit_code] { *exit_code = Add(*args); });
  CLI::App* list =
      sub->add_subcommand("list", "List the tokens: hash prefix, role, created, label");
  db(list);
  list->callback([args, exit_code] { *exit_code = List(*args); });
  CLI::App* revoke = sub->add_subcommand("revoke", "Remove tokens by hash prefix or label");
  db(revoke);
  revoke->add_option("--hash", args->hash, "hash prefix from `matfit tokens list` (≥ 8 digits)");
  revoke->add_option("--label", args->label, "every token with this label");
  revoke->callback([args, exit_code] { *exit_code = Revoke(*args); });
}

}  // namespace matfit::app
