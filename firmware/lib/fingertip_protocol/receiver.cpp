#include "receiver.h"

#include <string.h>

#include "cobs.h"
#include "crc16.h"
#include "int24.h"

namespace ftp {

namespace {

uint16_t getU16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (static_cast<uint16_t>(p[1]) << 8));
}

int32_t readInt24(const uint8_t* p) {
  return signExtend24(static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
                      (static_cast<uint32_t>(p[2]) << 16));
}

uint8_t popcount16(uint16_t v) {
  uint8_t n = 0;
  for (; v != 0; v = static_cast<uint16_t>(v & (v - 1))) {
    ++n;
  }
  return n;
}

// Sets the verdict for a frame with a good CRC that cannot be executed.
void reject(RxResult& result, RxError error, NackError nack) {
  result.error = error;
  result.nack = nack;
}

}  // namespace

void parseCommandFrame(const uint8_t* frame, size_t len, RxResult& result) {
  memset(&result, 0, sizeof(result));  // unused argument fields read as 0
  if (len < kMinFrame) {
    result.error = RxError::TooShort;
    return;
  }
  const size_t body = len - kCrcSize;
  if (crc16(frame, body) != getU16(frame + body)) {
    result.error = RxError::Crc;
    return;
  }
  Command& c = result.command;
  c.type = static_cast<MsgType>(frame[0]);
  c.request_id = getU16(frame + 1);
  const uint8_t* p = frame + kHeaderSize;
  const size_t n = body - kHeaderSize;

  // Expected payload length per type; a length mismatch is judged before the arguments.
  size_t expected;
  switch (c.type) {
    case MsgType::Ping:
    case MsgType::GetInfo:
    case MsgType::Start:
    case MsgType::Stop:
    case MsgType::ResetCounters:
    case MsgType::GetStats:
      expected = 0;
      break;
    case MsgType::Tare:
      expected = 4;
      break;
    case MsgType::SetRate:
      expected = 2;
      break;
    case MsgType::SetGain:
    case MsgType::SetPower:
      expected = 1;
      break;
    case MsgType::SetTareOffsets:
      // Variable length: the mask says how many int24 offsets follow.
      expected = n >= 2 ? 2 + 3 * static_cast<size_t>(popcount16(getU16(p))) : 2;
      break;
    default:  // device message types land here too: not a command
      reject(result, RxError::UnknownType, NackError::UnknownCommand);
      return;
  }
  if (n != expected) {
    reject(result, RxError::BadPayload, NackError::BadLength);
    return;
  }

  bool ok = true;
  switch (c.type) {
    case MsgType::Tare:
      c.channel_mask = getU16(p);
      c.samples = getU16(p + 2);
      ok = c.channel_mask != 0 && c.samples <= kMaxTareSamples;
      break;
    case MsgType::SetRate:
      c.rate_sps = p[0];
      c.decimation = p[1];
      ok = (c.rate_sps == 10 || c.rate_sps == 80) && c.decimation != 0;
      break;
    case MsgType::SetGain:
      c.gain = p[0];
      ok = c.gain == 128 || c.gain == 64 || c.gain == 32;
      break;
    case MsgType::SetPower:
      c.on = p[0];
      ok = c.on <= 1;
      break;
    case MsgType::SetTareOffsets: {
      c.channel_mask = getU16(p);
      ok = c.channel_mask != 0;
      const uint8_t* q = p + 2;
      for (uint8_t i = 0; i < kMaxChannels; ++i) {
        if ((c.channel_mask >> i) & 1u) {
          c.offsets[i] = readInt24(q);
          q += 3;
        }
      }
      break;
    }
    default:
      break;
  }
  if (!ok) {
    reject(result, RxError::BadPayload, NackError::BadArgument);
    return;
  }
  result.error = RxError::None;
}

CommandReceiver::CommandReceiver() : len_(0), overflow_(false) { resetCounters(); }

void CommandReceiver::clear() {
  len_ = 0;
  overflow_ = false;
}

void CommandReceiver::resetCounters() { memset(&counters_, 0, sizeof(counters_)); }

bool CommandReceiver::feed(uint8_t byte, RxResult& result) {
  if (byte != 0x00) {
    if (len_ < kMaxEncoded) {
      buf_[len_++] = byte;
    } else {
      overflow_ = true;  // stop storing; the run ends at the next delimiter
    }
    return false;
  }
  judge(result);
  clear();
  return true;
}

bool CommandReceiver::feed(const uint8_t* data, size_t len, size_t& consumed,
                           RxResult& result) {
  for (size_t i = 0; i < len; ++i) {
    if (feed(data[i], result)) {
      consumed = i + 1;
      return true;
    }
  }
  consumed = len;
  return false;
}

void CommandReceiver::judge(RxResult& result) {
  if (len_ == 0) {  // an overflow always has stored kMaxEncoded bytes
    memset(&result, 0, sizeof(result));
    result.error = RxError::Empty;
    ++counters_.empty_frames;
    return;
  }
  if (overflow_) {
    memset(&result, 0, sizeof(result));
    result.error = RxError::TooLong;
    ++counters_.overflows;
    return;
  }
  size_t n = 0;
  if (!cobsDecode(buf_, len_, buf_, sizeof(buf_), &n)) {
    memset(&result, 0, sizeof(result));
    result.error = RxError::Cobs;
    ++counters_.framing_errors;
    return;
  }
  parseCommandFrame(buf_, n, result);
  switch (result.error) {
    case RxError::None:
      ++counters_.commands_ok;
      break;
    case RxError::TooShort:
      ++counters_.framing_errors;
      break;
    case RxError::Crc:
      ++counters_.crc_errors;
      break;
    default:  // UnknownType, BadPayload
      ++counters_.rejected;
      break;
  }
}

}  // namespace ftp
