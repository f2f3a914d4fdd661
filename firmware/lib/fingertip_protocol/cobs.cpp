#include "cobs.h"

namespace ftp {

size_t cobsEncode(const uint8_t* src, size_t len, uint8_t* dst, size_t cap) {
  if (cap == 0) {
    return 0;
  }
  size_t code_pos = 0;  // where the current block's code byte goes, once its length is known
  size_t w = 1;
  uint8_t code = 1;
  for (size_t i = 0; i < len; ++i) {
    const uint8_t b = src[i];  // read before any write to the same byte (in-place use)
    if (w >= cap) {
      return 0;
    }
    if (b == 0) {
      dst[code_pos] = code;
      code_pos = w++;
      code = 1;
    } else {
      dst[w++] = b;
      ++code;
      if (code == 0xFF) {
        // A full block of 254 data bytes carries no implied zero; a new block starts even at
        // the very end (then as a lone 0x01), which is what the reference generator emits.
        dst[code_pos] = code;
        if (w >= cap) {
          return 0;
        }
        code_pos = w++;
        code = 1;
      }
    }
  }
  dst[code_pos] = code;
  return w;
}

bool cobsDecode(const uint8_t* src, size_t len, uint8_t* dst, size_t cap, size_t* out_len) {
  if (len == 0) {
    return false;  // not even a code byte
  }
  size_t r = 0;
  size_t w = 0;
  while (r < len) {
    const uint8_t code = src[r++];
    if (code == 0) {
      return false;
    }
    const size_t n = static_cast<size_t>(code - 1);
    if (n > len - r) {
      return false;  // the block runs past the received bytes
    }
    if (n > cap - w) {
      return false;
    }
    for (size_t k = 0; k < n; ++k) {
      dst[w++] = src[r++];
    }
    if (code != 0xFF && r < len) {
      if (w >= cap) {
        return false;
      }
      dst[w++] = 0;
    }
  }
  *out_len = w;
  return true;
}

}  // namespace ftp
