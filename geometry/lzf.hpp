// LZF decompression (Marc Lehmann's liblzf format), for PCD's DATA binary_compressed: the format is
// small enough to decode here, so the build needs no liblzf and a hostile block can be bounded first.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace cmm::geometry {

// A compressed block that does not decode to what it claims; `offset` is the byte of the block where
// decoding went wrong.
struct LzfError : std::runtime_error {
  LzfError(std::size_t offset, const std::string& message) : std::runtime_error(message), offset(offset) {}
  std::size_t offset;
};

// One LZF byte of input gives at most this many of output (a back reference of 3 bytes copies 264),
// so a claimed size beyond compressed × this is a lie to refuse before allocating for it.
inline constexpr std::size_t lzf_max_expansion = 88;

// Decodes `compressed` into exactly `size` bytes; LzfError when it holds fewer or more, or a back
// reference points before the start of the output.
std::string lzf_decompress(std::string_view compressed, std::size_t size);

}  // namespace cmm::geometry
