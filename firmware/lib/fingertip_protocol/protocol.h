// Wire protocol v1: constants, type codes and device-message structs.
// The byte layout lives in docs/protocol.md; this header only names it.
#ifndef FINGERTIP_PROTOCOL_PROTOCOL_H
#define FINGERTIP_PROTOCOL_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

namespace ftp {

const uint8_t kProtocolMajor = 1;
const uint8_t kProtocolMinor = 0;

const uint8_t kHeaderSize = 3;  // type u8 + seq/request id u16
const uint8_t kCrcSize = 2;
const uint8_t kMinFrame = kHeaderSize + kCrcSize;
const uint8_t kMaxFrame = 128;    // header and CRC included
const uint8_t kMaxEncoded = 129;  // one COBS code byte per started 254-byte block
const uint8_t kMaxWire = kMaxEncoded + 1;  // plus the 0x00 delimiter: size of a TX buffer
const uint8_t kMaxChannels = 16;  // the masks are u16
const uint8_t kMaxLogText = 100;
const uint16_t kMaxTareSamples = 256;  // TARE samples (0 clears the offsets)

const int32_t kInt24Max = 8388607;   // 0x7FFFFF
const int32_t kInt24Min = -8388608;  // -0x800000

// Bit 7 set = device to host. A MsgType variable may hold any byte (fixed underlying type),
// which is how an unknown received type is carried to the NACK that echoes it.
enum class MsgType : uint8_t {
  // Commands (host to device).
  Ping = 0x01,
  GetInfo = 0x02,
  Start = 0x03,
  Stop = 0x04,
  Tare = 0x05,
  SetRate = 0x06,
  SetGain = 0x07,
  ResetCounters = 0x08,
  SetPower = 0x09,
  GetStats = 0x0A,
  SetTareOffsets = 0x0B,
  // Device messages (device to host).
  Sample = 0x81,
  Info = 0x82,
  Stats = 0x83,
  Ack = 0x84,
  Nack = 0x85,
  Log = 0x86,
};

// NACK error codes (section 5.1). None = 0 is ours: "nothing to answer with a NACK".
enum class NackError : uint8_t {
  None = 0,
  UnknownCommand = 1,
  BadLength = 2,
  BadArgument = 3,
  Busy = 4,
  ChipTimeout = 5,
  PoweredDown = 6,
};

// What a receiver concluded about the bytes before a delimiter (section 2.3, in check order).
enum class RxError : uint8_t {
  None = 0,  // a valid command
  Empty,
  TooLong,
  Cobs,
  TooShort,
  Crc,
  UnknownType,
  BadPayload,
};

enum class LogLevel : uint8_t { Debug = 0, Info = 1, Warning = 2, Error = 3 };

// INFO reason and flags bits.
const uint8_t kInfoReasonRequest = 0;
const uint8_t kInfoReasonBoot = 1;
const uint8_t kFlagStreaming = 0x01;
const uint8_t kFlagPoweredDown = 0x02;
const uint8_t kFlagTareInProgress = 0x04;

// SAMPLE payload. values[i] for i >= channels are ignored.
struct Sample {
  uint32_t timestamp_us;
  uint8_t channels;  // 1..kMaxChannels
  uint16_t timeout_mask;
  uint16_t saturation_mask;
  int32_t values[kMaxChannels];  // int24 range, already clipped by the caller
};

// INFO payload.
struct Info {
  uint8_t protocol_major;
  uint8_t protocol_minor;
  uint8_t firmware_version[3];  // major, minor, patch
  uint32_t build_id;
  uint8_t reason;       // kInfoReasonRequest or kInfoReasonBoot
  uint8_t reset_cause;  // MCUSR at boot
  uint8_t channels;     // 1..kMaxChannels
  uint8_t rate_sps;
  uint8_t decimation;
  uint8_t gain;
  uint8_t flags;  // kFlag* bits
  uint16_t tare_mask;
  int32_t tare_offsets[kMaxChannels];  // int24 range
};

// STATS payload: ten wrapping u32 counters, in wire order. The one list of their names in
// C++: the struct, the encoder and the host library's name table are all made from it, and
// tests check it against tests/vectors/protocol_v1.json (as the host's STATS_FIELDS is).
#define FTP_STATS_FIELDS(X) \
  X(timestamp_us)           \
  X(frames_sent)            \
  X(read_timeouts)          \
  X(saturations)            \
  X(command_errors)         \
  X(rx_overflows)           \
  X(rx_crc_errors)          \
  X(rx_framing_errors)      \
  X(tx_overruns)            \
  X(longest_loop_us)

#define FTP_STATS_DECLARE(name) uint32_t name;
struct Stats {
  FTP_STATS_FIELDS(FTP_STATS_DECLARE)
};
#undef FTP_STATS_DECLARE

// Payload sizes of section 4 (SAMPLE and INFO: before their 3 bytes per channel).
const uint8_t kSamplePayloadFixed = 9;
const uint8_t kInfoPayloadFixed = 18;
const uint8_t kStatsPayload = sizeof(Stats);
const uint8_t kAckPayload = 3;
const uint8_t kNackPayload = 4;

// True if no bit at or above `channels` is set (masks of SAMPLE, and the TARE channel mask).
// The guard matters on AVR: shifting a 16-bit int by 16 is undefined.
inline bool maskFitsChannels(uint16_t mask, uint8_t channels) {
  return channels >= kMaxChannels || (mask >> channels) == 0;
}

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_PROTOCOL_H
