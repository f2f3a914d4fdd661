#include "encoder.h"

#include "cobs.h"
#include "crc16.h"

namespace ftp {

namespace {

// Little-endian writers; each returns the position after what it wrote.
uint8_t* putU8(uint8_t* p, uint8_t v) {
  *p = v;
  return p + 1;
}

uint8_t* putU16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
  return p + 2;
}

uint8_t* putU32(uint8_t* p, uint32_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
  p[2] = static_cast<uint8_t>(v >> 16);
  p[3] = static_cast<uint8_t>(v >> 24);
  return p + 4;
}

uint8_t* putI24(uint8_t* p, int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);  // modular: two's complement bytes
  p[0] = static_cast<uint8_t>(u);
  p[1] = static_cast<uint8_t>(u >> 8);
  p[2] = static_cast<uint8_t>(u >> 16);
  return p + 3;
}

bool inInt24(int32_t v) { return v >= kInt24Min && v <= kInt24Max; }

bool allInInt24(const int32_t* v, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) {
    if (!inInt24(v[i])) {
      return false;
    }
  }
  return true;
}

size_t frameLen(size_t payload_len) { return kHeaderSize + payload_len + kCrcSize; }

}  // namespace

uint8_t* Encoder::begin(MsgType type, size_t frame_len, uint8_t* out, size_t cap) const {
  // The frame is built at out + 1 and encoded into out: one COBS code byte in front (v1
  // frames are far below 254 bytes) and the delimiter behind. No second buffer needed.
  if (out == nullptr || frame_len > kMaxFrame || cap < frame_len + 2) {
    return nullptr;
  }
  uint8_t* p = putU8(out + 1, static_cast<uint8_t>(type));
  return putU16(p, seq_);
}

size_t Encoder::finish(uint8_t* out, uint8_t* end) {
  uint8_t* frame = out + 1;
  const size_t body = static_cast<size_t>(end - frame);
  end = putU16(end, crc16(frame, body));
  const size_t frame_len = body + kCrcSize;
  const size_t n = cobsEncode(frame, frame_len, out, frame_len + 1);
  out[n] = 0x00;
  seq_ = static_cast<uint16_t>(seq_ + 1);  // wraps 65535 -> 0
  return n + 1;
}

size_t Encoder::encodeSample(const Sample& m, uint8_t* out, size_t cap) {
  if (m.channels == 0 || m.channels > kMaxChannels ||
      !maskFitsChannels(m.timeout_mask, m.channels) ||
      !maskFitsChannels(m.saturation_mask, m.channels) || !allInInt24(m.values, m.channels)) {
    return 0;
  }
  uint8_t* p = begin(MsgType::Sample, frameLen(kSamplePayloadFixed + 3u * m.channels), out, cap);
  if (p == nullptr) {
    return 0;
  }
  p = putU32(p, m.timestamp_us);
  p = putU8(p, m.channels);
  p = putU16(p, m.timeout_mask);
  p = putU16(p, m.saturation_mask);
  for (uint8_t i = 0; i < m.channels; ++i) {
    p = putI24(p, m.values[i]);
  }
  return finish(out, p);
}

size_t Encoder::encodeInfo(const Info& m, uint8_t* out, size_t cap) {
  if (m.channels == 0 || m.channels > kMaxChannels || !allInInt24(m.tare_offsets, m.channels)) {
    return 0;
  }
  uint8_t* p = begin(MsgType::Info, frameLen(kInfoPayloadFixed + 3u * m.channels), out, cap);
  if (p == nullptr) {
    return 0;
  }
  p = putU8(p, m.protocol_major);
  p = putU8(p, m.protocol_minor);
  for (uint8_t i = 0; i < 3; ++i) {
    p = putU8(p, m.firmware_version[i]);
  }
  p = putU32(p, m.build_id);
  p = putU8(p, m.reason);
  p = putU8(p, m.reset_cause);
  p = putU8(p, m.channels);
  p = putU8(p, m.rate_sps);
  p = putU8(p, m.decimation);
  p = putU8(p, m.gain);
  p = putU8(p, m.flags);
  p = putU16(p, m.tare_mask);
  for (uint8_t i = 0; i < m.channels; ++i) {
    p = putI24(p, m.tare_offsets[i]);
  }
  return finish(out, p);
}

size_t Encoder::encodeStats(const Stats& m, uint8_t* out, size_t cap) {
  uint8_t* p = begin(MsgType::Stats, frameLen(kStatsPayload), out, cap);
  if (p == nullptr) {
    return 0;
  }
#define FTP_PUT_STAT(name) p = putU32(p, m.name);
  FTP_STATS_FIELDS(FTP_PUT_STAT)
#undef FTP_PUT_STAT
  return finish(out, p);
}

size_t Encoder::encodeAck(uint16_t request_id, MsgType command, uint8_t* out, size_t cap) {
  uint8_t* p = begin(MsgType::Ack, frameLen(kAckPayload), out, cap);
  if (p == nullptr) {
    return 0;
  }
  p = putU16(p, request_id);
  p = putU8(p, static_cast<uint8_t>(command));
  return finish(out, p);
}

size_t Encoder::encodeNack(uint16_t request_id, MsgType command, NackError error, uint8_t* out,
                           size_t cap) {
  if (error == NackError::None) {
    return 0;
  }
  uint8_t* p = begin(MsgType::Nack, frameLen(kNackPayload), out, cap);
  if (p == nullptr) {
    return 0;
  }
  p = putU16(p, request_id);
  p = putU8(p, static_cast<uint8_t>(command));
  p = putU8(p, static_cast<uint8_t>(error));
  return finish(out, p);
}

size_t Encoder::encodeLog(LogLevel level, const char* text, size_t len, uint8_t* out,
                          size_t cap) {
  if (static_cast<uint8_t>(level) > static_cast<uint8_t>(LogLevel::Error) || len > kMaxLogText ||
      (text == nullptr && len != 0)) {
    return 0;
  }
  uint8_t* p = begin(MsgType::Log, frameLen(1 + len), out, cap);
  if (p == nullptr) {
    return 0;
  }
  p = putU8(p, static_cast<uint8_t>(level));
  for (size_t i = 0; i < len; ++i) {
    p = putU8(p, static_cast<uint8_t>(text[i]));
  }
  return finish(out, p);
}

}  // namespace ftp
