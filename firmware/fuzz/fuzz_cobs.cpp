// libFuzzer target: the protocol's COBS decoder (lib/fingertip_protocol/cobs.cpp).
//
// Whatever the bytes, cobsDecode must stay inside its buffers (ASan), never overflow an
// integer (UBSan), agree with itself in place and out of place, and what it accepts must
// re-encode to something that decodes to the same bytes. Any input must also survive the
// round trip encode -> decode unchanged. A broken property calls __builtin_trap(): libFuzzer
// reports it as a crash with the input that caused it.
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "cobs.h"
#include "protocol.h"

namespace {

void require(bool ok) {
  if (!ok) __builtin_trap();
}

// Room for the firmware's largest frame and far beyond: the decoder must honour cap.
constexpr size_t kCap = 4 * ftp::kMaxEncoded;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > kCap) return 0;  // the receiver never holds more than kMaxEncoded bytes
  // The first byte picks the output capacity, so that "does not fit" is exercised too.
  size_t cap = size ? (data[0] % (kCap + 1)) : kCap;

  uint8_t out[kCap];
  size_t out_len = 0;
  bool ok = ftp::cobsDecode(data, size, out, cap, &out_len);
  if (ok) require(out_len <= cap && out_len < size + 1);

  // In place (dst == src) must give the same verdict and bytes.
  uint8_t inplace[kCap];
  memcpy(inplace, data, size);
  size_t in_len = 0;
  bool ok2 = ftp::cobsDecode(inplace, size, inplace, cap, &in_len);
  require(ok == ok2);
  if (ok) require(in_len == out_len && memcmp(inplace, out, out_len) == 0);

  if (ok) {  // what was accepted re-encodes to an encoding of the same bytes
    uint8_t enc[kCap + kCap / 254 + 2];
    size_t n = ftp::cobsEncode(out, out_len, enc, sizeof enc);
    require(n > 0 && n <= ftp::cobsMaxEncoded(out_len));
    for (size_t i = 0; i < n; ++i) require(enc[i] != 0);  // no delimiter inside
    uint8_t back[kCap];
    size_t back_len = 0;
    require(ftp::cobsDecode(enc, n, back, sizeof back, &back_len));
    require(back_len == out_len && memcmp(back, out, out_len) == 0);
  }

  // Any bytes round-trip through encode -> decode.
  uint8_t enc[kCap + kCap / 254 + 2];
  size_t n = ftp::cobsEncode(data, size, enc, sizeof enc);
  require(n > 0 && n <= ftp::cobsMaxEncoded(size));
  uint8_t back[kCap];
  size_t back_len = 0;
  require(ftp::cobsDecode(enc, n, back, sizeof back, &back_len));
  require(back_len == size && memcmp(back, data, size) == 0);
  return 0;
}
