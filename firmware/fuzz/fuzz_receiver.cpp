// libFuzzer target: the firmware's command receiver (lib/fingertip_protocol/receiver.cpp),
// fed the bytes a host (or line noise) could send over the UART.
//
// Properties checked on every input, besides ASan/UBSan: byte-wise and chunk-wise feeding
// give the same verdicts and counters; every delimiter increments exactly one counter; a
// command reported valid has arguments inside the protocol's ranges; a rejected intact
// command carries a NACK code; the receiver keeps working after any input (a valid PING
// after garbage and a delimiter is accepted).
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "cobs.h"
#include "crc16.h"
#include "protocol.h"
#include "receiver.h"

namespace {

void require(bool ok) {
  if (!ok) __builtin_trap();
}

uint32_t total(const ftp::RxCounters& c) {
  return c.commands_ok + c.empty_frames + c.overflows + c.framing_errors + c.crc_errors +
         c.rejected;
}

bool same(const ftp::RxResult& a, const ftp::RxResult& b) {
  if (a.error != b.error) return false;
  if (a.error == ftp::RxError::None || a.error == ftp::RxError::UnknownType ||
      a.error == ftp::RxError::BadPayload) {
    return a.nack == b.nack && a.command.type == b.command.type &&
           a.command.request_id == b.command.request_id;
  }
  return true;
}

void checkValid(const ftp::RxResult& r) {
  if (r.error != ftp::RxError::None) return;
  const ftp::Command& c = r.command;
  switch (c.type) {
    case ftp::MsgType::Tare:
      require(c.channel_mask != 0 && c.samples <= 256);
      break;
    case ftp::MsgType::SetRate:
      require((c.rate_sps == 10 || c.rate_sps == 80) && c.decimation != 0);
      break;
    case ftp::MsgType::SetGain:
      require(c.gain == 128 || c.gain == 64 || c.gain == 32);
      break;
    case ftp::MsgType::SetPower:
      require(c.on <= 1);
      break;
    case ftp::MsgType::SetTareOffsets:
      require(c.channel_mask != 0);
      for (uint8_t i = 0; i < ftp::kMaxChannels; ++i) {
        require(c.offsets[i] >= -8388608 && c.offsets[i] <= 8388607);
      }
      break;
    default:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ftp::CommandReceiver bytewise;
  ftp::CommandReceiver chunked;
  ftp::RxResult a;
  uint32_t delimiters = 0;
  if (size > (1u << 16)) return 0;

  // Byte by byte, remembering each verdict.
  static ftp::RxResult verdicts[1 << 16];
  size_t nv = 0;
  for (size_t i = 0; i < size; ++i) {
    if (bytewise.feed(data[i], a)) {
      ++delimiters;
      checkValid(a);
      if (a.error == ftp::RxError::UnknownType || a.error == ftp::RxError::BadPayload) {
        require(a.nack != ftp::NackError::None);
      }
      if (nv < sizeof verdicts / sizeof verdicts[0]) verdicts[nv++] = a;
    }
  }
  require(total(bytewise.counters()) == delimiters);

  // The same bytes in chunks whose sizes come from the data itself.
  size_t pos = 0, k = 0;
  while (pos < size) {
    size_t want = 1 + data[pos] % 37;
    if (want > size - pos) want = size - pos;
    size_t consumed = 0;
    ftp::RxResult r;
    bool got = chunked.feed(data + pos, want, consumed, r);
    require(consumed >= 1 && consumed <= want);
    pos += consumed;
    if (got) {
      require(k < nv || nv == sizeof verdicts / sizeof verdicts[0]);
      if (k < nv) require(same(r, verdicts[k]));
      ++k;
    }
  }
  require(k == delimiters);
  require(memcmp(&bytewise.counters(), &chunked.counters(), sizeof(ftp::RxCounters)) == 0);

  // The pure frame judge on the raw input as if it were one decoded frame.
  ftp::RxResult p;
  ftp::parseCommandFrame(data, size, p);
  checkValid(p);

  // Whatever came before, a delimiter then a well-formed PING is accepted.
  uint8_t frame[8] = {static_cast<uint8_t>(ftp::MsgType::Ping), 0x34, 0x12};
  size_t flen = 3;
  uint16_t crc = ftp::crc16(frame, flen);
  frame[flen++] = static_cast<uint8_t>(crc & 0xFF);  // little-endian, as on the wire
  frame[flen++] = static_cast<uint8_t>(crc >> 8);
  uint8_t wire[16];
  size_t n = ftp::cobsEncode(frame, flen, wire + 1, sizeof wire - 2);
  require(n > 0);
  wire[0] = 0;
  wire[n + 1] = 0;
  ftp::RxResult last;
  for (size_t i = 0; i < n + 2; ++i) bytewise.feed(wire[i], last);
  require(last.error == ftp::RxError::None && last.command.type == ftp::MsgType::Ping &&
          last.command.request_id == 0x1234);
  return 0;
}
