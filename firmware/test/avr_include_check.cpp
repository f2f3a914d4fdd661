// Compiled (not linked) by `make avr-check`: the sketch will include Arduino.h before the
// protocol headers, and Arduino.h defines many short macros (min, max, B0..B11111111, register
// and bit names). This catches a clash at build time instead of in the first sketch.
#include <Arduino.h>

#include "fingertip_protocol.h"

// Touch each part so that the headers are instantiated, not just parsed.
size_t avrIncludeCheck(uint8_t* out, size_t cap) {
  static ftp::Encoder enc;
  static ftp::CommandReceiver rx;
  ftp::RxResult r;
  bool sat = false;
  const int32_t v = ftp::sampleValue(0x123456UL, 0, sat);
  if (rx.feed(static_cast<uint8_t>(v), r) && r.error == ftp::RxError::None) {
    return enc.encodeAck(r.command.request_id, r.command.type, out, cap);
  }
  return ftp::cobsEncode(out, 0, out, cap) + ftp::crc16(out, 0);
}
