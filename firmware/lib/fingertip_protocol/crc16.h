// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, MSB first, no reflection, no final XOR.
// Equals Python's binascii.crc_hqx(data, 0xFFFF); check value of "123456789" is 0x29B1.
#ifndef FINGERTIP_PROTOCOL_CRC16_H
#define FINGERTIP_PROTOCOL_CRC16_H

#include <stddef.h>
#include <stdint.h>

namespace ftp {

const uint16_t kCrcInit = 0xFFFF;

// Feeds one byte into a running CRC.
uint16_t crc16Update(uint16_t crc, uint8_t byte);

// CRC of len bytes; pass a previous result as crc to continue over several pieces.
uint16_t crc16(const uint8_t* data, size_t len, uint16_t crc = kCrcInit);

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_CRC16_H
