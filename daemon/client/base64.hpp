// Base64 (RFC 4648, with padding) as model.upload carries a model's bytes in JSON, and as cmmctl
// sends them; OpenSSL does the coding, this file the strict checking a wire format needs.
#pragma once

#include <string>
#include <string_view>

namespace cmm::daemon {

std::string encode_base64(std::string_view bytes);

// The bytes `text` encodes. Refuses anything but the standard alphabet in groups of four with
// '=' padding at the very end (no whitespace, no URL alphabet): std::invalid_argument naming the
// first bad character and its position.
std::string decode_base64(std::string_view text);

}  // namespace cmm::daemon
