// 24-bit helpers for HX711 readings (docs/protocol.md section 3). Inline: the firmware calls
// them per channel per conversion.
#ifndef FINGERTIP_PROTOCOL_INT24_H
#define FINGERTIP_PROTOCOL_INT24_H

#include <stdint.h>

#include "protocol.h"

namespace ftp {

// Two's-complement 24-bit word (bits above 23 ignored) to int32.
// Flipping the sign bit and subtracting 2^23 avoids converting an out-of-range unsigned
// value to signed, which C++11 leaves implementation-defined.
inline int32_t signExtend24(uint32_t raw) {
  return static_cast<int32_t>((raw & 0xFFFFFFUL) ^ 0x800000UL) + kInt24Min;
}

// True if the chip reported its limit (0x7FFFFF or 0x800000): input out of range.
inline bool isSaturatedRaw(uint32_t raw) {
  raw &= 0xFFFFFFUL;
  return raw == 0x7FFFFFUL || raw == 0x800000UL;
}

// Clips to int24; sets saturated (never clears it) when v was outside the range, so one flag
// can collect several causes.
inline int32_t clipInt24(int32_t v, bool& saturated) {
  if (v > kInt24Max) {
    saturated = true;
    return kInt24Max;
  }
  if (v < kInt24Min) {
    saturated = true;
    return kInt24Min;
  }
  return v;
}

// The value a SAMPLE carries: raw reading minus the tare offset, clipped to int24.
// saturated is set if the chip was at its limit or the subtraction was clipped.
// offset must be in int24 range, so the difference cannot overflow int32.
inline int32_t sampleValue(uint32_t raw, int32_t offset, bool& saturated) {
  if (isSaturatedRaw(raw)) {
    saturated = true;
  }
  return clipInt24(signExtend24(raw) - offset, saturated);
}

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_INT24_H
