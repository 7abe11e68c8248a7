// LZF's two kinds of token: a control byte below 32 is a run of (control + 1) literal bytes; above it
// is a back reference of length (control >> 5) + 2 (7 means another byte of length follows) at a
// distance of ((control & 31) << 8) + the next byte + 1 behind the output's end, which may overlap
// what it copies (a run).
#include "geometry/lzf.hpp"

namespace cmm::geometry {

std::string lzf_decompress(std::string_view compressed, std::size_t size) {
  if (size > compressed.size() * lzf_max_expansion)
    throw LzfError(0, std::to_string(compressed.size()) + " compressed bytes cannot hold " + std::to_string(size) +
                          " bytes (LZF expands at most " + std::to_string(lzf_max_expansion) + " times)");
  std::string out(size, '\0');
  std::size_t in = 0, at = 0;
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(compressed[i]); };
  while (in < compressed.size()) {
    const std::size_t token = in;
    const unsigned control = byte(in++);
    if (control < 32) {
      const std::size_t length = control + 1;
      if (compressed.size() - in < length)
        throw LzfError(token, "a literal run of " + std::to_string(length) + " bytes runs past the end of the block");
      if (size - at < length) throw LzfError(token, "decodes to more than the " + std::to_string(size) + " bytes announced");
      compressed.copy(out.data() + at, length, in);
      in += length;
      at += length;
      continue;
    }
    std::size_t length = control >> 5;
    if (length == 7) {
      if (in == compressed.size()) throw LzfError(token, "a back reference is cut off by the end of the block");
      length += byte(in++);
    }
    if (in == compressed.size()) throw LzfError(token, "a back reference is cut off by the end of the block");
    const std::size_t distance = ((control & 31U) << 8) + byte(in++) + 1;
    length += 2;
    if (distance > at)
      throw LzfError(token, "a back reference reaches " + std::to_string(distance) + " bytes back, before the start");
    if (size - at < length) throw LzfError(token, "decodes to more than the " + std::to_string(size) + " bytes announced");
    for (std::size_t k = 0; k < length; ++k, ++at) out[at] = out[at - distance];  // byte by byte: a run overlaps
  }
  if (at != size)
    throw LzfError(compressed.size(), "decodes to " + std::to_string(at) + " bytes, not the " + std::to_string(size) +
                                          " announced");
  return out;
}

}  // namespace cmm::geometry
