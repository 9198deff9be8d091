// Messages from the shared readers and fits speak of `matfit` command-line flags ("pass --layout
// lp"); an API client sets job fields instead. ApiWording rewrites every flag a message names:
// flags the API has become its job field, the others are named as settings that are not job
// fields (so no response tells a client to pass a flag it cannot pass).
#pragma once

#include <string>

namespace matfit::server {

std::string ApiWording(std::string message);

}  // namespace matfit::server
