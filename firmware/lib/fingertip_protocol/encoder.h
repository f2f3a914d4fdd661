// Device-side encoder: device messages to complete wire bytes (COBS frame + 0x00 delimiter).
#ifndef FINGERTIP_PROTOCOL_ENCODER_H
#define FINGERTIP_PROTOCOL_ENCODER_H

#include <stddef.h>
#include <stdint.h>

#include "protocol.h"

namespace ftp {

// Owns the device sequence counter, which all message types share (section 2.4).
// Every encodeX() writes into out (capacity cap; kMaxWire always suffices) and returns the
// number of bytes to send, delimiter included; or 0, with out's content undefined and seq
// unchanged, if an argument is out of range or cap is too small. seq advances only on success,
// so a frame the caller then fails to send (a TX overrun) shows up as a gap at the host.
class Encoder {
 public:
  Encoder() : seq_(0) {}

  uint16_t seq() const { return seq_; }  // the seq the next frame will carry
  void setSeq(uint16_t seq) { seq_ = seq; }

  // channels 1..16, mask bits only below channels, values in int24 range (clip them first).
  size_t encodeSample(const Sample& m, uint8_t* out, size_t cap);
  // channels 1..16, tare offsets in int24 range.
  size_t encodeInfo(const Info& m, uint8_t* out, size_t cap);
  size_t encodeStats(const Stats& m, uint8_t* out, size_t cap);
  size_t encodeAck(uint16_t request_id, MsgType command, uint8_t* out, size_t cap);
  // error must not be NackError::None.
  size_t encodeNack(uint16_t request_id, MsgType command, NackError error, uint8_t* out,
                    size_t cap);
  // len <= kMaxLogText bytes of UTF-8 (not checked), no terminator needed.
  size_t encodeLog(LogLevel level, const char* text, size_t len, uint8_t* out, size_t cap);

 private:
  // Checks room for a frame of frame_len bytes (CRC included), writes the header at out + 1
  // and returns where the payload goes, or nullptr.
  uint8_t* begin(MsgType type, size_t frame_len, uint8_t* out, size_t cap) const;
  // Appends the CRC after the payload ending at end, COBS-encodes in place, adds the
  // delimiter, advances seq; returns the wire length.
  size_t finish(uint8_t* out, uint8_t* end);

  uint16_t seq_;
};

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_ENCODER_H
