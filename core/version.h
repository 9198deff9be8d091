#pragma once
namespace matfit {
inline constexpr const char* kMatfitVersion = "0.1.0";
}
