// Base64 through OpenSSL's EVP_EncodeBlock / EVP_DecodeBlock, after checking what they would let
// through (EVP_DecodeBlock skips blanks and counts padding as zero bytes).
#include "daemon/client/base64.hpp"

#include <openssl/evp.h>

#include <stdexcept>

namespace cmm::daemon {

namespace {
bool in_alphabet(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
}

[[noreturn]] void refuse(std::string_view text, std::size_t at, const std::string& why) {
  std::string shown = at < text.size() ? "'" + std::string(1, text[at]) + "' " : "";
  throw std::invalid_argument("invalid base64: " + shown + "at position " + std::to_string(at) + ": " + why);
}
}  // namespace

std::string encode_base64(std::string_view bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3), '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::string decode_base64(std::string_view text) {
  if (text.size() % 4 != 0) refuse(text, text.size(), "length " + std::to_string(text.size()) + " is not a multiple of 4");
  std::size_t padding = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '=') {
      // '=' only in the last group's last one or two places, and nothing but '=' after it.
      if (i + 2 < text.size() || (i + 2 == text.size() && text[i + 1] != '=')) refuse(text, i, "padding before the end");
      ++padding;
    } else if (!in_alphabet(text[i])) {
      refuse(text, i, "not in the base64 alphabet");
    }
  }
  std::string out(3 * (text.size() / 4), '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(text.data()), static_cast<int>(text.size()));
  if (n < 0) refuse(text, 0, "rejected by the decoder");
  out.resize(static_cast<std::size_t>(n) - padding);
  return out;
}

}  // namespace cmm::daemon
