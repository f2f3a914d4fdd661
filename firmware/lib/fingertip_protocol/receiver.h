// Device-side command receiver: bytes from the UART in, judged commands out (section 2.3, 5).
#ifndef FINGERTIP_PROTOCOL_RECEIVER_H
#define FINGERTIP_PROTOCOL_RECEIVER_H

#include <stddef.h>
#include <stdint.h>

#include "protocol.h"

namespace ftp {

// A command with its arguments; only the fields of its type are meaningful, the others are 0.
struct Command {
  MsgType type;  // may hold an unknown byte, to be echoed in a NACK
  uint16_t request_id;
  uint16_t channel_mask;  // TARE (the decoder does not know the channel count: firmware checks)
  uint16_t samples;       // TARE, 0..256 (0 clears the offsets)
  uint8_t rate_sps;       // SET_RATE, 10 or 80
  uint8_t decimation;     // SET_RATE, 1..255
  uint8_t gain;           // SET_GAIN, 128, 64 or 32
  uint8_t on;             // SET_POWER, 0 or 1
  // SET_TARE_OFFSETS: indexed by channel; only channels in channel_mask were sent (others 0).
  int32_t offsets[kMaxChannels];
};

struct RxResult {
  RxError error;  // None: command is valid and complete
  // Not None for intact but malformed commands (UnknownType, BadPayload): answer
  // NACK(command.request_id, command.type, nack). Garbled frames get no answer.
  NackError nack;
  Command command;  // type and request_id are set whenever the CRC was good
};

// Wrapping u32 counters; every delimiter increments exactly one of them.
struct RxCounters {
  uint32_t commands_ok;
  uint32_t empty_frames;    // not errors (section 2.3)
  uint32_t overflows;       // too_long, once per over-long run
  uint32_t framing_errors;  // cobs + too_short
  uint32_t crc_errors;
  uint32_t rejected;  // unknown_type + bad_payload (each answered by a NACK)
};

// Judges one COBS-decoded frame (no delimiter): length, CRC, type, payload and arguments.
// Pure; the receiver below uses it after decoding.
void parseCommandFrame(const uint8_t* frame, size_t len, RxResult& result);

class CommandReceiver {
 public:
  CommandReceiver();

  // Feeds one received byte. Returns true when it was a delimiter; result then holds the
  // verdict on the bytes before it (its error may be Empty). Returns false otherwise and
  // leaves result untouched.
  bool feed(uint8_t byte, RxResult& result);

  // Same for a chunk (e.g. what a UART read returned): consumes bytes up to and including the
  // first delimiter and reports how many in consumed. Returns true if a delimiter ended the
  // consumed bytes (result set); call again with the rest.
  bool feed(const uint8_t* data, size_t len, size_t& consumed, RxResult& result);

  // Drops a partially received frame (for instance after a UART error); keeps the counters.
  void clear();

  const RxCounters& counters() const { return counters_; }
  void resetCounters();

 private:
  void judge(RxResult& result);

  uint8_t buf_[kMaxEncoded];  // decoded in place, so no second buffer
  uint8_t len_;
  bool overflow_;
  RxCounters counters_;
};

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_RECEIVER_H
