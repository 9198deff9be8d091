// Text from clients and for clients: UTF-8 checks, printable renderings of hostile bytes for
// messages, and the one JSON serialisation of the server (never throws on bad UTF-8).
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

namespace matfit::server {

// Well-formed UTF-8: no stray continuation bytes, no truncated sequences, no overlong forms,
// no surrogates, nothing above U+10FFFF.
bool IsUtf8(std::string_view s);
// The first control byte (< 0x20 or 0x7f) of `s`, or -1.
int FirstControlByte(std::string_view s);
// `s` for a message: bytes that are not UTF-8, and control bytes, as \xNN (at most 200 bytes).
std::string Printable(std::string_view s);
// j as JSON text (indent < 0: one line); invalid UTF-8 becomes U+FFFD instead of throwing.
std::string JsonText(const nlohmann::json& j, int indent = -1);

}  // namespace matfit::server
