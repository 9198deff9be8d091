// Helpers of the browser tests (headless Chromium): find the browser, run a command and keep its
// output, decode the pages' base64 pixel probes.
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace matfit::render {

inline std::string FindChromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"})
    if (std::filesystem::exists(p)) return p;
  return "";
}

inline std::string RunCommand(const std::string& cmd) {
  std::string out;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
  if (!pipe) return out;
  std::array<char, 65536> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe.get())) > 0) out.append(buf.data(), n);
  return out;
}

inline std::string Base64Decode(const std::string& in) {
  std::string out;
  int val = 0, bits = -8;
  for (unsigned char c : in) {
    int d;
    if (c >= 'A' && c <= 'Z')
      d = c - 'A';
    else if (c >= 'a' && c <= 'z')
      d = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      d = c - '0' + 52;
    else if (c == '+')
      d = 62;
    else if (c == '/')
      d = 63;
    else
      continue;
    val = (val << 6) + d, bits += 6;
    if (bits >= 0) out.push_back(char((val >> bits) & 0xff)), bits -= 8;
  }
  return out;
}

// The Chromium flags every browser test uses: headless, WebGL2 on SwiftShader, no first-run or
// network chatter.
inline constexpr char kHeadlessFlags[] =
    " --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader"
    " --no-first-run --disable-background-networking --disable-component-update --disable-sync";

}  // namespace matfit::render
