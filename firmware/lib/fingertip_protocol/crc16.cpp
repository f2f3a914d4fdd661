#include "crc16.h"

#ifdef __AVR__
#include <util/crc16.h>
#endif

namespace ftp {

uint16_t crc16Update(uint16_t crc, uint8_t byte) {
#ifdef __AVR__
  // avr-libc's XMODEM routine is the same MSB-first 0x1021 CRC (XMODEM only differs by its
  // init value, which the caller supplies), in a few cycles of asm and no table in flash.
  // Not _crc_ccitt_update: that one is reflected.
  return _crc_xmodem_update(crc, byte);
#else
  // Bitwise: at most a few hundred bytes per frame, a table would not pay for itself.
  crc = static_cast<uint16_t>(crc ^ (static_cast<uint16_t>(byte) << 8));
  for (uint8_t bit = 0; bit < 8; ++bit) {
    if (crc & 0x8000u) {
      crc = static_cast<uint16_t>((crc << 1) ^ 0x1021u);
    } else {
      crc = static_cast<uint16_t>(crc << 1);
    }
  }
  return crc;
#endif
}

uint16_t crc16(const uint8_t* data, size_t len, uint16_t crc) {
  for (size_t i = 0; i < len; ++i) {
    crc = crc16Update(crc, data[i]);
  }
  return crc;
}

}  // namespace ftp
