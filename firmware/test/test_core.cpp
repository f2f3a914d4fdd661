// Native tests of the device logic (lib/fingertip_core): docs/protocol.md sections 5 and 6,
// driven through a scripted board (chips, clock, UART) instead of the Uno.
#include "doctest_setup.h"  // doctest with its main (or PlatformIO's)

#include <cstring>
#include <deque>
#include <string>
#include <vector>

#include "fingertip_core.h"

namespace {

using Bytes = std::vector<uint8_t>;
using ftp::MsgType;
using ftp::NackError;

// Checks inside helpers that run hundreds of thousands of times: an assertion only when it
// fails, so that a runner printing every successful assertion (PlatformIO) stays readable.
#define ENSURE(cond)   \
  do {                 \
    if (!(cond)) {     \
      REQUIRE(cond);   \
    }                  \
  } while (0)

const uint32_t kT80 = 12500;   // conversion period at 80 SPS, us
const uint32_t kT10 = 100000;  // at 10 SPS

// ---------------------------------------------------------------------------------------------
// Wire helpers

std::string hex(const Bytes& b) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (uint8_t x : b) {
    s += digits[x >> 4];
    s += digits[x & 0xF];
  }
  return s;
}

// A host command as wire bytes: header, payload, CRC, COBS, delimiter.
Bytes command(uint8_t type, uint16_t rid, const Bytes& payload = {}) {
  Bytes f = {type, static_cast<uint8_t>(rid), static_cast<uint8_t>(rid >> 8)};
  f.insert(f.end(), payload.begin(), payload.end());
  const uint16_t crc = ftp::crc16(f.data(), f.size());
  f.push_back(static_cast<uint8_t>(crc));
  f.push_back(static_cast<uint8_t>(crc >> 8));
  Bytes out(ftp::cobsMaxEncoded(f.size()) + 1);
  const size_t n = ftp::cobsEncode(f.data(), f.size(), out.data(), out.size());
  ENSURE(n > 0);
  out.resize(n);
  out.push_back(0);
  return out;
}

Bytes u16le(uint16_t v) { return {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8)}; }

Bytes tarePayload(uint16_t mask, uint16_t samples) {
  Bytes p = u16le(mask);
  const Bytes s = u16le(samples);
  p.insert(p.end(), s.begin(), s.end());
  return p;
}

Bytes int24le(int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  return {static_cast<uint8_t>(u), static_cast<uint8_t>(u >> 8), static_cast<uint8_t>(u >> 16)};
}

// One decoded device frame.
struct Msg {
  uint8_t type = 0;
  uint16_t seq = 0;
  Bytes p;  // payload

  uint8_t u8(size_t o) const { return p.at(o); }
  uint16_t u16(size_t o) const { return static_cast<uint16_t>(p.at(o) | (p.at(o + 1) << 8)); }
  uint32_t u32(size_t o) const {
    return static_cast<uint32_t>(p.at(o)) | (static_cast<uint32_t>(p.at(o + 1)) << 8) |
           (static_cast<uint32_t>(p.at(o + 2)) << 16) | (static_cast<uint32_t>(p.at(o + 3)) << 24);
  }
  int32_t i24(size_t o) const {
    return ftp::signExtend24(static_cast<uint32_t>(p.at(o)) |
                             (static_cast<uint32_t>(p.at(o + 1)) << 8) |
                             (static_cast<uint32_t>(p.at(o + 2)) << 16));
  }
  bool is(MsgType t) const { return type == static_cast<uint8_t>(t); }

  // SAMPLE
  uint32_t timestamp() const { return u32(0); }
  uint8_t channels() const { return u8(4); }
  uint16_t timeoutMask() const { return u16(5); }
  uint16_t saturationMask() const { return u16(7); }
  int32_t value(uint8_t ch) const { return i24(9 + 3u * ch); }
  // ACK / NACK
  uint16_t requestId() const { return u16(0); }
  uint8_t command() const { return u8(2); }
  uint8_t error() const { return u8(3); }
  // INFO
  uint8_t infoFlags() const { return u8(15); }
  uint16_t infoTareMask() const { return u16(16); }
  int32_t infoOffset(uint8_t ch) const { return i24(18 + 3u * ch); }
  // STATS (field index 0..9)
  uint32_t stat(int i) const { return u32(4u * static_cast<size_t>(i)); }
};

enum StatField {
  kStatTime, kFramesSent, kReadTimeouts, kSaturations, kCommandErrors, kRxOverflows,
  kRxCrcErrors, kRxFramingErrors, kTxOverruns, kLongestLoop
};

// Splits the device's byte stream into frames; any damage fails the test.
class Decoder {
 public:
  size_t empty_frames = 0;

  std::vector<Msg> feed(const Bytes& bytes) {
    std::vector<Msg> out;
    for (uint8_t b : bytes) {
      if (b != 0) {
        buf_.push_back(b);
        continue;
      }
      if (buf_.empty()) {
        ++empty_frames;
        continue;
      }
      Bytes frame(buf_.size());
      size_t n = 0;
      ENSURE(ftp::cobsDecode(buf_.data(), buf_.size(), frame.data(), frame.size(), &n));
      frame.resize(n);
      ENSURE(n >= ftp::kMinFrame);
      const uint16_t crc = static_cast<uint16_t>(frame[n - 2] | (frame[n - 1] << 8));
      ENSURE(ftp::crc16(frame.data(), n - 2) == crc);
      Msg m;
      m.type = frame[0];
      m.seq = static_cast<uint16_t>(frame[1] | (frame[2] << 8));
      m.p.assign(frame.begin() + 3, frame.end() - 2);
      ENSURE((m.type & 0x80) != 0);
      out.push_back(m);
      buf_.clear();
    }
    return out;
  }

 private:
  Bytes buf_;
};

// ---------------------------------------------------------------------------------------------
// The scripted board

struct FakeBoard : ftc::Hal {
  uint32_t now = 0;

  // HX711s. With auto_convert, every alive chip converts once per period while powered;
  // otherwise tests set `ready` by hand.
  bool auto_convert = true;
  uint16_t alive = 0xFFFF;
  uint16_t ready = 0;      // DOUT low (a conversion waits)
  uint16_t stuck_low = 0;  // DOUT always low (broken chip)
  int32_t value[16] = {};  // what each chip outputs, int24
  uint32_t next_conv = 0;
  bool powered = false;
  bool rate80 = false;
  std::vector<bool> power_log;
  std::vector<uint8_t> pulses;       // SCK pulses of every read
  std::vector<uint16_t> read_ready;  // DOUT-low mask at every read
  std::vector<uint32_t> read_time;

  // UART.
  std::deque<uint8_t> rx;
  uint16_t tx_free = 1000;
  Bytes tx;

  uint32_t period() const { return rate80 ? kT80 : kT10; }

  uint32_t nowUs() override { return now; }
  uint16_t readyMask() override { return static_cast<uint16_t>(ready | stuck_low); }
  void readChips(uint8_t p, uint32_t* raw) override {
    pulses.push_back(p);
    read_ready.push_back(readyMask());
    read_time.push_back(now);
    for (int i = 0; i < 16; ++i) {
      // A chip not ready leaves DOUT high (pull-up): all ones.
      raw[i] = ((readyMask() >> i) & 1) ? static_cast<uint32_t>(value[i]) & 0xFFFFFFu
                                        : 0xFFFFFFu;
    }
    ready = 0;  // pulse 25 sets DOUT high again
  }
  void setPower(bool on) override {
    powered = on;
    power_log.push_back(on);
    ready = 0;
    next_conv = now + period();
  }
  void setRate80(bool fast) override {
    if (fast != rate80 && powered) next_conv = now + 4 * (fast ? kT80 : kT10);  // settling
    rate80 = fast;
  }
  int16_t rxByte() override {
    if (rx.empty()) return -1;
    const uint8_t b = rx.front();
    rx.pop_front();
    return b;
  }
  uint16_t txFree() override { return tx_free; }
  void txWrite(const uint8_t* data, uint8_t len) override {
    ENSURE(len <= tx_free);
    tx.insert(tx.end(), data, data + len);
  }

  // One step of the chips' clock.
  void tick() {
    if (auto_convert && powered && static_cast<int32_t>(now - next_conv) >= 0) {
      ready = static_cast<uint16_t>(ready | alive);
      next_conv += period();
    }
  }
};

struct Bench {
  FakeBoard hal;
  std::vector<ftc::ChannelState> state;
  ftc::Device dev;
  Decoder dec;
  Bytes boot_bytes;
  std::vector<Msg> boot_msgs;

  explicit Bench(uint8_t channels = 4, uint32_t build_id = 0, uint8_t reset_cause = 1,
                 uint32_t start_us = 0)
      : state(channels), dev(hal, state.data(), ftc::DeviceConfig{channels, build_id, reset_cause}) {
    hal.now = start_us;
    dev.boot();
    boot_bytes = hal.tx;
    boot_msgs = collect();
  }

  std::vector<Msg> collect() {
    std::vector<Msg> m = dec.feed(hal.tx);
    hal.tx.clear();
    return m;
  }

  // Sends bytes and polls (without moving time) until they are consumed.
  std::vector<Msg> sendBytes(const Bytes& b) {
    hal.rx.insert(hal.rx.end(), b.begin(), b.end());
    for (int guard = 0; !hal.rx.empty() && guard < 10000; ++guard) dev.poll();
    dev.poll();
    return collect();
  }
  std::vector<Msg> send(uint8_t type, uint16_t rid, const Bytes& payload = {}) {
    return sendBytes(command(type, rid, payload));
  }
  std::vector<Msg> send(MsgType type, uint16_t rid, const Bytes& payload = {}) {
    return send(static_cast<uint8_t>(type), rid, payload);
  }

  // Runs device time forward by `us`, polling every `step` us.
  std::vector<Msg> run(uint32_t us, uint32_t step = 100) {
    std::vector<Msg> out;
    for (uint32_t t = 0; t < us; t += step) {
      hal.now += step;
      hal.tick();
      dev.poll();
      std::vector<Msg> m = collect();
      out.insert(out.end(), m.begin(), m.end());
    }
    return out;
  }

  Msg stats() {
    std::vector<Msg> m = send(MsgType::GetStats, 999);
    REQUIRE(m.size() == 2);
    REQUIRE(m[0].is(MsgType::Stats));
    return m[0];
  }
  Msg info() {
    std::vector<Msg> m = send(MsgType::GetInfo, 998);
    REQUIRE(m.size() == 2);
    REQUIRE(m[0].is(MsgType::Info));
    return m[0];
  }
};

std::vector<Msg> only(const std::vector<Msg>& v, MsgType t) {
  std::vector<Msg> out;
  for (const Msg& m : v) {
    if (m.is(t)) out.push_back(m);
  }
  return out;
}

void checkAck(const Msg& m, uint16_t rid, MsgType cmd) {
  CHECK(m.is(MsgType::Ack));
  CHECK(m.requestId() == rid);
  CHECK(m.command() == static_cast<uint8_t>(cmd));
}

void checkNack(const Msg& m, uint16_t rid, uint8_t cmd, NackError e) {
  CHECK(m.is(MsgType::Nack));
  CHECK(m.requestId() == rid);
  CHECK(m.command() == cmd);
  CHECK(m.error() == static_cast<uint8_t>(e));
}

}  // namespace

// =============================================================================================
// Boot

TEST_CASE("boot: lone 0x00, INFO (reason 1, seq 0), LOG; exact bytes") {
  Bench b(4, 0, 1);
  // Same bytes as host/fingertip/sim/device/virtual_firmware.py VirtualFirmware(4).boot().
  CHECK(hex(b.boot_bytes) ==
        "0002820102010102010101010107010104500180010101010101010101010101010103"
        "75db00038601220166696e67657274697020667720302e312e302c2034206368616e6e65"
        "6c731b7200");
  REQUIRE(b.boot_msgs.size() == 2);
  CHECK(b.dec.empty_frames == 1);
  const Msg& info = b.boot_msgs[0];
  CHECK(info.is(MsgType::Info));
  CHECK(info.seq == 0);
  CHECK(info.u8(0) == 1);    // protocol major
  CHECK(info.u8(1) == 0);    // minor
  CHECK(info.u8(2) == 0);    // firmware 0.1.0
  CHECK(info.u8(3) == 1);
  CHECK(info.u8(4) == 0);
  CHECK(info.u8(9) == 1);    // reason: boot
  CHECK(info.u8(10) == 1);   // reset cause
  CHECK(info.u8(11) == 4);   // channels
  CHECK(info.u8(12) == 80);  // rate
  CHECK(info.u8(13) == 1);   // decimation
  CHECK(info.u8(14) == 128); // gain
  CHECK(info.infoFlags() == 0);
  CHECK(info.infoTareMask() == 0);
  const Msg& log = b.boot_msgs[1];
  CHECK(log.is(MsgType::Log));
  CHECK(log.seq == 1);
  CHECK(log.u8(0) == 1);
  CHECK(std::string(log.p.begin() + 1, log.p.end()) == "fingertip fw 0.1.0, 4 channels");
  // Powered up, at 80 SPS; nothing else comes out while not streaming.
  CHECK(b.hal.powered);
  CHECK(b.hal.rate80);
  CHECK(b.run(3000000).empty());
  CHECK(!b.hal.pulses.empty());  // ...but the chips are read all the time
}

TEST_CASE("boot: 16 channels, build id and reset cause") {
  Bench b16(16, 0, 1);
  CHECK(hex(b16.boot_bytes) ==
        "000282010201010201010101010701011050018001010101010101010101010101010101"
        "010101010101010101010101010101010101010101010101010101010101010101010363"
        "e000038601230166696e67657274697020667720302e312e302c203136206368616e6e65"
        "6c7338bc00");
  Bench b(4, 0xc0dcceaa, 0x08);
  const Msg& info = b.boot_msgs[0];
  CHECK(info.u32(5) == 0xc0dcceaaU);
  CHECK(info.u8(10) == 0x08);  // watchdog reset
}

// =============================================================================================
// Commands

TEST_CASE("commands: each answered once, in order, INFO/STATS before the ACK") {
  Bench b;
  std::vector<Msg> m = b.send(MsgType::Ping, 1);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 1, MsgType::Ping);
  CHECK(m[0].seq == 2);

  m = b.send(MsgType::GetInfo, 2);
  REQUIRE(m.size() == 2);
  CHECK(m[0].is(MsgType::Info));
  CHECK(m[0].u8(9) == 0);  // reason: request
  checkAck(m[1], 2, MsgType::GetInfo);

  m = b.send(MsgType::GetStats, 3);
  REQUIRE(m.size() == 2);
  CHECK(m[0].is(MsgType::Stats));
  CHECK(m[0].p.size() == 40);
  CHECK(m[0].stat(kFramesSent) == 5);  // boot INFO + LOG, ACK, INFO, ACK; not this one
  checkAck(m[1], 3, MsgType::GetStats);

  // Several commands in one burst: answered in arrival order.
  Bytes burst;
  for (uint16_t rid = 10; rid < 15; ++rid) {
    const Bytes c = command(0x01, rid);
    burst.insert(burst.end(), c.begin(), c.end());
  }
  m = b.sendBytes(burst);
  REQUIRE(m.size() == 5);
  for (uint16_t i = 0; i < 5; ++i) {
    checkAck(m[i], static_cast<uint16_t>(10 + i), MsgType::Ping);
    CHECK(m[i].seq == 7 + i);  // after boot (0, 1), 2, 3-4, 5-6
  }
}

TEST_CASE("commands: START / STOP gate the samples; START twice is ACKed") {
  Bench b;
  b.hal.value[0] = 42;
  std::vector<Msg> m = b.send(MsgType::Start, 1);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 1, MsgType::Start);
  CHECK(b.dev.streaming());
  CHECK((b.info().infoFlags() & ftp::kFlagStreaming) != 0);
  m = b.send(MsgType::Start, 2);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 2, MsgType::Start);
  std::vector<Msg> out = b.run(100000);
  std::vector<Msg> samples = only(out, MsgType::Sample);
  CHECK(samples.size() == 8);  // 80 SPS for 0.1 s
  CHECK(samples[0].value(0) == 42);
  CHECK(samples[0].channels() == 4);
  CHECK(samples[0].p.size() == 9 + 12);
  m = b.send(MsgType::Stop, 3);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 3, MsgType::Stop);
  CHECK(only(b.run(2000000), MsgType::Sample).empty());
  CHECK(only(b.run(2000000), MsgType::Stats).empty());
}

TEST_CASE("commands: malformed frames are NACKed with the right code") {
  Bench b;
  std::vector<Msg> m;
  m = b.send(0x0C, 1);  // not a command
  REQUIRE(m.size() == 1);
  checkNack(m[0], 1, 0x0C, NackError::UnknownCommand);
  m = b.send(0x84, 2, {1, 0, 1});  // an ACK sent to the device
  REQUIRE(m.size() == 1);
  checkNack(m[0], 2, 0x84, NackError::UnknownCommand);
  m = b.send(MsgType::Ping, 3, {0});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 3, 0x01, NackError::BadLength);
  m = b.send(MsgType::SetRate, 4, {80});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 4, 0x06, NackError::BadLength);
  m = b.send(MsgType::SetRate, 5, {40, 1});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 5, 0x06, NackError::BadArgument);
  m = b.send(MsgType::SetRate, 6, {80, 0});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 6, 0x06, NackError::BadArgument);
  m = b.send(MsgType::SetGain, 7, {100});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 7, 0x07, NackError::BadArgument);
  m = b.send(MsgType::SetPower, 8, {2});
  REQUIRE(m.size() == 1);
  checkNack(m[0], 8, 0x09, NackError::BadArgument);
  m = b.send(MsgType::Tare, 9, tarePayload(0, 4));
  REQUIRE(m.size() == 1);
  checkNack(m[0], 9, 0x05, NackError::BadArgument);
  m = b.send(MsgType::Tare, 10, tarePayload(1, 257));
  REQUIRE(m.size() == 1);
  checkNack(m[0], 10, 0x05, NackError::BadArgument);
  m = b.send(MsgType::Tare, 11, tarePayload(0x10, 4));  // channel 4 on a 4-channel device
  REQUIRE(m.size() == 1);
  checkNack(m[0], 11, 0x05, NackError::BadArgument);
  Bytes sto = u16le(0x10);
  const Bytes v = int24le(5);
  sto.insert(sto.end(), v.begin(), v.end());
  m = b.send(MsgType::SetTareOffsets, 12, sto);
  REQUIRE(m.size() == 1);
  checkNack(m[0], 12, 0x0B, NackError::BadArgument);
  // Nothing changed.
  CHECK(b.dev.rateSps() == 80);
  CHECK(b.dev.gain() == 128);
  CHECK(b.dev.powered());
  CHECK(b.stats().stat(kCommandErrors) == 12);
}

TEST_CASE("commands: garbled frames are counted, not answered; the receiver recovers") {
  Bench b;
  Bytes bad_crc = command(0x01, 1);
  bad_crc[bad_crc.size() - 2] ^= 0x01;
  CHECK(b.sendBytes(bad_crc).empty());
  CHECK(b.sendBytes({0x05, 0x01, 0x00}).empty());  // COBS block runs past the end
  CHECK(b.sendBytes({0x02, 0x01, 0x00}).empty());  // decodes to 1 byte: too short
  Bytes long_run(300, 0x11);
  long_run.push_back(0);
  CHECK(b.sendBytes(long_run).empty());
  CHECK(b.sendBytes({0x00, 0x00}).empty());  // empty frames: not errors
  std::vector<Msg> m = b.send(MsgType::Ping, 2);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 2, MsgType::Ping);
  const Msg s = b.stats();
  CHECK(s.stat(kRxCrcErrors) == 1);
  CHECK(s.stat(kRxFramingErrors) == 2);
  CHECK(s.stat(kRxOverflows) == 1);
  CHECK(s.stat(kCommandErrors) == 0);
}

TEST_CASE("commands: SET_RATE sets the RATE pin, decimation and waits for settling") {
  Bench b;
  b.run(50000);
  std::vector<Msg> m = b.send(MsgType::SetRate, 1, {10, 2});
  REQUIRE(m.size() == 1);
  checkAck(m[0], 1, MsgType::SetRate);
  CHECK(!b.hal.rate80);
  CHECK(b.dev.rateSps() == 10);
  CHECK(b.dev.decimation() == 2);
  // The chips settle for 4 periods at the new rate: no timeout before 5.5 periods.
  CHECK(b.dev.deadlineUs() == b.hal.now + 4 * kT10 + kT10 + kT10 / 2);
  const Msg i = b.info();
  CHECK(i.u8(12) == 10);
  CHECK(i.u8(13) == 2);
  b.send(MsgType::Start, 2);
  std::vector<Msg> samples = only(b.run(2000000), MsgType::Sample);
  CHECK(samples.size() == 8);  // 0.4 s settling, then 10 SPS, every 2nd: 16 / 2 in 2 s
  for (size_t k = 1; k < samples.size(); ++k) {
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() == 2 * kT10);
    CHECK(samples[k].timeoutMask() == 0);
  }
  // Same rate, new decimation: the pin is not touched, no settling.
  const uint32_t deadline = b.dev.deadlineUs();
  m = b.send(MsgType::SetRate, 3, {10, 1});
  checkAck(m[0], 3, MsgType::SetRate);
  CHECK(b.dev.deadlineUs() == deadline);
}

TEST_CASE("commands: SET_GAIN changes the pulse count and discards one reading") {
  Bench b;
  b.hal.value[0] = 1000;
  b.send(MsgType::Start, 1);
  b.run(30000);  // 2 samples at gain 128
  CHECK(b.hal.pulses.back() == 25);
  std::vector<Msg> m = b.send(MsgType::SetGain, 2, {64});
  checkAck(m[0], 2, MsgType::SetGain);
  const size_t reads_before = b.hal.pulses.size();
  std::vector<Msg> out = b.run(50000);  // 4 conversions
  CHECK(b.hal.pulses.size() == reads_before + 4);
  CHECK(b.hal.pulses.back() == 27);
  CHECK(only(out, MsgType::Sample).size() == 3);  // the first one after the change is dropped
  m = b.send(MsgType::SetGain, 3, {32});
  b.run(kT80);
  CHECK(b.hal.pulses.back() == 26);
  // Changing the gain and back before any read discards nothing.
  b.send(MsgType::SetGain, 4, {128});
  b.send(MsgType::SetGain, 5, {32});
  out = b.run(2 * kT80);
  CHECK(only(out, MsgType::Sample).size() == 2);
  CHECK(b.info().u8(14) == 32);
}

TEST_CASE("commands: a gain change makes the next wait include the 4-period settling") {
  Bench b;
  b.run(6 * kT80);  // past the settling after boot
  b.hal.auto_convert = false;
  const uint32_t t0 = b.hal.read_time.back();
  CHECK(b.dev.deadlineUs() == t0 + kT80 + kT80 / 2);
  b.send(MsgType::SetGain, 1, {64});
  b.hal.now = t0 + kT80;
  b.hal.ready = 0xF;
  b.run(100);  // this reading still has gain 128: discarded, chips now settle
  const uint32_t t1 = b.hal.read_time.back();
  CHECK(b.dev.deadlineUs() == t1 + 4 * kT80 + kT80 + kT80 / 2);
  // No timeouts while they settle.
  b.run(4 * kT80);
  CHECK(b.stats().stat(kReadTimeouts) == 0);
}

TEST_CASE("commands: SET_POWER powers down and up; START and TARE refused while down") {
  Bench b;
  b.send(MsgType::Start, 1);
  std::vector<Msg> m = b.send(MsgType::SetPower, 2, {0});
  REQUIRE(m.size() == 1);
  checkAck(m[0], 2, MsgType::SetPower);
  CHECK(!b.hal.powered);
  CHECK(!b.dev.streaming());  // powering down stops the stream
  const Msg i = b.info();
  CHECK(i.infoFlags() == ftp::kFlagPoweredDown);
  m = b.send(MsgType::Start, 3);
  checkNack(m[0], 3, 0x03, NackError::PoweredDown);
  m = b.send(MsgType::Tare, 4, tarePayload(1, 4));
  checkNack(m[0], 4, 0x05, NackError::PoweredDown);
  m = b.send(MsgType::Tare, 5, tarePayload(1, 0));
  checkNack(m[0], 5, 0x05, NackError::PoweredDown);
  const size_t reads = b.hal.pulses.size();
  CHECK(b.run(1000000).empty());
  CHECK(b.hal.pulses.size() == reads);  // no reads while powered down
  m = b.send(MsgType::SetPower, 6, {0});  // already down: ACK, nothing else
  checkAck(m[0], 6, MsgType::SetPower);
  CHECK(b.hal.power_log.size() == 2);  // boot (on), down
  m = b.send(MsgType::SetPower, 7, {1});
  checkAck(m[0], 7, MsgType::SetPower);
  CHECK(b.hal.powered);
  CHECK(b.hal.power_log.back());
  // Power-up: settle 4 periods before any timeout.
  CHECK(b.dev.deadlineUs() == b.hal.now + 5 * kT80 + kT80 / 2);
  m = b.send(MsgType::Start, 8);
  checkAck(m[0], 8, MsgType::Start);
  std::vector<Msg> samples = only(b.run(100000), MsgType::Sample);
  CHECK(samples.size() == 8);
  CHECK(b.stats().stat(kReadTimeouts) == 0);
}

TEST_CASE("commands: power-up with gain 64 discards the first reading (chips restart at 128)") {
  Bench b;
  b.send(MsgType::SetGain, 1, {64});
  b.run(2 * kT80);
  b.send(MsgType::SetPower, 2, {0});
  b.send(MsgType::SetPower, 3, {1});
  b.send(MsgType::Start, 4);
  std::vector<Msg> samples = only(b.run(5 * kT80), MsgType::Sample);
  CHECK(samples.size() == 4);  // 5 conversions, the first discarded
  CHECK(b.hal.pulses.back() == 27);
}

TEST_CASE("commands: RESET_COUNTERS zeroes every STATS counter") {
  Bench b;
  b.send(0x0C, 1);
  Bytes bad = command(0x01, 2);
  bad[1] ^= 0xFF;
  b.sendBytes(bad);
  b.hal.alive = 0x7;  // channel 3 dead
  b.run(100000);
  Msg s = b.stats();
  CHECK(s.stat(kCommandErrors) == 1);
  CHECK(s.stat(kReadTimeouts) > 0);
  CHECK(s.stat(kLongestLoop) == 100);
  std::vector<Msg> m = b.send(MsgType::ResetCounters, 3);
  checkAck(m[0], 3, MsgType::ResetCounters);
  s = b.stats();
  CHECK(s.stat(kFramesSent) == 1);  // the ACK of RESET_COUNTERS
  for (int f = kReadTimeouts; f <= kLongestLoop; ++f) {
    CHECK(s.stat(f) == 0);
  }
}

TEST_CASE("commands: SET_TARE_OFFSETS sets the offsets used by the samples") {
  Bench b;
  for (int i = 0; i < 4; ++i) b.hal.value[i] = 100 * (i + 1);
  Bytes p = u16le(0b0101);
  for (int32_t v : {10, -8388608}) {
    const Bytes x = int24le(v);
    p.insert(p.end(), x.begin(), x.end());
  }
  std::vector<Msg> m = b.send(MsgType::SetTareOffsets, 1, p);
  REQUIRE(m.size() == 1);
  checkAck(m[0], 1, MsgType::SetTareOffsets);
  CHECK(b.dev.offset(0) == 10);
  CHECK(b.dev.offset(1) == 0);
  CHECK(b.dev.offset(2) == -8388608);
  const Msg i = b.info();
  CHECK(i.infoTareMask() == 0b0101);
  CHECK(i.infoOffset(2) == -8388608);
  b.send(MsgType::Start, 2);
  const Msg s = only(b.run(kT80), MsgType::Sample).at(0);
  CHECK(s.value(0) == 90);
  CHECK(s.value(1) == 200);
  CHECK(s.value(2) == 8388607);  // 300 + 8388608 clipped
  CHECK(s.saturationMask() == 0b0100);
  // Wrong length for the mask: BAD_LENGTH.
  m = b.send(MsgType::SetTareOffsets, 3, u16le(0b0011));
  checkNack(m[0], 3, 0x0B, NackError::BadLength);
}

// =============================================================================================
// Tare

TEST_CASE("tare: averages raw readings, ACK after the last one's SAMPLE, then subtracts") {
  Bench b;
  b.hal.value[0] = 1000;
  b.hal.value[1] = -2001;
  b.hal.value[2] = 7;
  b.send(MsgType::Start, 1);
  CHECK(b.send(MsgType::Tare, 2, tarePayload(0b0011, 8)).empty());  // answered when done
  CHECK(b.dev.tareActive());
  CHECK((b.info().infoFlags() & ftp::kFlagTareInProgress) != 0);
  std::vector<Msg> out = b.run(200000);
  size_t ack_at = out.size();
  for (size_t k = 0; k < out.size(); ++k) {
    if (out[k].is(MsgType::Ack) && out[k].requestId() == 2) ack_at = k;
  }
  REQUIRE(ack_at < out.size());
  checkAck(out[ack_at], 2, MsgType::Tare);
  // 8 samples with the old offsets (the last right before the ACK), the rest with the new.
  size_t before = 0;
  for (size_t k = 0; k < out.size(); ++k) {
    if (!out[k].is(MsgType::Sample)) continue;
    if (k < ack_at) {
      ++before;
      CHECK(out[k].value(0) == 1000);
    } else {
      CHECK(out[k].value(0) == 0);
      CHECK(out[k].value(1) == 0);
      CHECK(out[k].value(2) == 7);
    }
  }
  CHECK(before == 8);
  CHECK(out[ack_at - 1].is(MsgType::Sample));
  CHECK(!b.dev.tareActive());
  const Msg i = b.info();
  CHECK(i.infoOffset(0) == 1000);
  CHECK(i.infoOffset(1) == -2001);
  CHECK(i.infoTareMask() == 0b0011);
  // samples = 0 clears at once.
  std::vector<Msg> m = b.send(MsgType::Tare, 3, tarePayload(0b0001, 0));
  REQUIRE(m.size() == 1);
  checkAck(m[0], 3, MsgType::Tare);
  CHECK(b.dev.offset(0) == 0);
  CHECK(b.dev.offset(1) == -2001);
}

TEST_CASE("tare: works without streaming; rounds half away from zero") {
  Bench b;
  b.hal.auto_convert = false;
  b.run(1000);
  b.send(MsgType::Tare, 1, tarePayload(0b1111, 2));
  // Two readings per channel: sums 5, -5, 3, -3 -> averages 2.5, -2.5, 1.5, -1.5.
  const int32_t first[4] = {2, -2, 1, -1};
  const int32_t second[4] = {3, -3, 2, -2};
  for (int i = 0; i < 4; ++i) b.hal.value[i] = first[i];
  b.hal.ready = 0xF;
  CHECK(b.run(100).empty());
  for (int i = 0; i < 4; ++i) b.hal.value[i] = second[i];
  b.hal.now += kT80;
  b.hal.ready = 0xF;
  std::vector<Msg> out = b.run(100);
  REQUIRE(out.size() == 1);  // not streaming: only the ACK
  checkAck(out[0], 1, MsgType::Tare);
  CHECK(b.dev.offset(0) == 3);
  CHECK(b.dev.offset(1) == -3);
  CHECK(b.dev.offset(2) == 2);
  CHECK(b.dev.offset(3) == -2);
}

TEST_CASE("tare: 256 samples at the int24 limits fit; clipping after the tare saturates") {
  Bench b;
  b.hal.value[0] = -8388608;
  b.hal.value[1] = 8388607;
  b.hal.value[2] = -3;
  b.send(MsgType::Tare, 1, tarePayload(0b0111, 256));
  std::vector<Msg> out = b.run(256 * kT80 + 1000, 500);
  REQUIRE(out.size() == 1);
  checkAck(out[0], 1, MsgType::Tare);
  CHECK(b.dev.offset(0) == -8388608);
  CHECK(b.dev.offset(1) == 8388607);
  CHECK(b.dev.offset(2) == -3);
  // Now the input swings to the other limit: the difference is clipped and flagged.
  b.hal.value[0] = 8388607;
  b.hal.value[1] = -8388608;
  b.hal.value[2] = 5;
  b.send(MsgType::Start, 2);
  const Msg s = only(b.run(kT80), MsgType::Sample).at(0);
  CHECK(s.value(0) == 8388607);
  CHECK(s.value(1) == -8388608);
  CHECK(s.value(2) == 8);
  CHECK(s.saturationMask() == 0b0011);
}

TEST_CASE("tare: takes samples x decimation conversions") {
  Bench b;
  b.send(MsgType::SetRate, 1, {80, 4});
  b.run(5 * kT80);  // through the settling
  const size_t reads = b.hal.pulses.size();
  b.send(MsgType::Tare, 2, tarePayload(1, 3));
  std::vector<Msg> out;
  while (out.empty()) {
    std::vector<Msg> m = b.run(100);
    out.insert(out.end(), m.begin(), m.end());
  }
  checkAck(out[0], 2, MsgType::Tare);
  // The first tare reading is the next kept one (1..4 conversions away), then 2 x 4 more.
  const size_t used = b.hal.pulses.size() - reads;
  CHECK(used > 2 * 4);
  CHECK(used <= 3 * 4);
}

TEST_CASE("tare: a masked channel timing out NACKs CHIP_TIMEOUT and keeps the old offsets") {
  Bench b;
  b.hal.value[2] = 50;
  Bytes p = u16le(0b0100);
  const Bytes x = int24le(123);
  p.insert(p.end(), x.begin(), x.end());
  b.send(MsgType::SetTareOffsets, 1, p);
  b.send(MsgType::Start, 2);
  b.run(30000);
  b.send(MsgType::Tare, 3, tarePayload(0b0110, 16));
  b.run(2 * kT80);
  b.hal.alive = 0b1011;  // channel 2 dies during the tare
  std::vector<Msg> out = b.run(100000);
  std::vector<Msg> nacks = only(out, MsgType::Nack);
  REQUIRE(nacks.size() == 1);
  checkNack(nacks[0], 3, 0x05, NackError::ChipTimeout);
  CHECK(!b.dev.tareActive());
  CHECK(b.dev.offset(1) == 0);
  CHECK(b.dev.offset(2) == 123);
  // The other channels keep streaming at the full rate, channel 2 flagged.
  std::vector<Msg> samples = only(out, MsgType::Sample);
  CHECK(samples.size() >= 7);
  CHECK(samples.back().timeoutMask() == 0b0100);
  CHECK(samples.back().value(2) == 0);
  CHECK(b.stats().stat(kCommandErrors) == 1);
}

TEST_CASE("tare: BUSY for TARE, SET_TARE_OFFSETS, SET_RATE, SET_GAIN, SET_POWER; others run") {
  Bench b;
  b.send(MsgType::Tare, 1, tarePayload(1, 100));
  std::vector<Msg> m;
  m = b.send(MsgType::Tare, 2, tarePayload(1, 1));
  checkNack(m[0], 2, 0x05, NackError::Busy);
  Bytes p = u16le(1);
  const Bytes x = int24le(1);
  p.insert(p.end(), x.begin(), x.end());
  m = b.send(MsgType::SetTareOffsets, 3, p);
  checkNack(m[0], 3, 0x0B, NackError::Busy);
  m = b.send(MsgType::SetRate, 4, {10, 1});
  checkNack(m[0], 4, 0x06, NackError::Busy);
  m = b.send(MsgType::SetGain, 5, {64});
  checkNack(m[0], 5, 0x07, NackError::Busy);
  m = b.send(MsgType::SetPower, 6, {0});
  checkNack(m[0], 6, 0x09, NackError::Busy);
  m = b.send(MsgType::Ping, 7);
  checkAck(m[0], 7, MsgType::Ping);
  m = b.send(MsgType::Start, 8);
  checkAck(m[0], 8, MsgType::Start);
  m = b.send(MsgType::Stop, 9);
  checkAck(m[0], 9, MsgType::Stop);
  CHECK(b.dev.rateSps() == 80);
  CHECK(b.dev.gain() == 128);
  CHECK(b.dev.powered());
  CHECK(b.dev.tareActive());
}

// =============================================================================================
// Readings

TEST_CASE("samples: timestamp is the ready time; values, saturation from the chip's limits") {
  Bench b;
  b.hal.value[0] = 1;
  b.hal.value[1] = -2;
  b.hal.value[2] = 8388607;   // 0x7FFFFF
  b.hal.value[3] = -8388608;  // 0x800000
  b.send(MsgType::Start, 1);
  std::vector<Msg> samples = only(b.run(2000000), MsgType::Sample);
  REQUIRE(samples.size() == 160);
  CHECK(samples[0].timestamp() == kT80);
  CHECK(samples[1].timestamp() == 2 * kT80);
  CHECK(samples[0].value(0) == 1);
  CHECK(samples[0].value(1) == -2);
  CHECK(samples[0].value(2) == 8388607);
  CHECK(samples[0].value(3) == -8388608);
  CHECK(samples[0].saturationMask() == 0b1100);
  CHECK(samples[0].timeoutMask() == 0);
  const Msg s = b.stats();
  CHECK(s.stat(kSaturations) == 2 * b.hal.pulses.size());
  CHECK(s.stat(kReadTimeouts) == 0);
  CHECK(b.hal.pulses.front() == 25);
}

TEST_CASE("samples: STATS once per second of device time while streaming") {
  Bench b;
  b.send(MsgType::Start, 1);
  std::vector<Msg> out = b.run(3000000);
  std::vector<Msg> stats = only(out, MsgType::Stats);
  REQUIRE(stats.size() == 3);
  CHECK(stats[1].stat(kStatTime) - stats[0].stat(kStatTime) == 1000000);
  CHECK(stats[2].stat(kStatTime) - stats[1].stat(kStatTime) == 1000000);
  CHECK(stats[0].stat(kFramesSent) > 80);
}

TEST_CASE("samples: decimation keeps every n-th conversion") {
  Bench b;
  b.send(MsgType::SetRate, 1, {80, 3});
  b.send(MsgType::Start, 2);
  b.run(5 * kT80);
  std::vector<Msg> samples = only(b.run(3 * kT80 * 10), MsgType::Sample);
  CHECK(samples.size() == 10);
  for (size_t k = 1; k < samples.size(); ++k) {
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() == 3 * kT80);
  }
}

TEST_CASE("samples: sequence numbers are shared and wrap 65535 -> 0") {
  Bench b;
  b.send(MsgType::Start, 1);
  std::vector<Msg> out = b.run(100000);
  for (size_t k = 1; k < out.size(); ++k) CHECK(out[k].seq == out[k - 1].seq + 1);
  std::vector<Msg> stop = b.send(MsgType::Stop, 2);
  REQUIRE(stop.size() == 1);
  CHECK(stop[0].seq == out.back().seq + 1);
  // Enough PINGs to pass the wrap.
  Bytes ping = command(0x01, 7);
  uint16_t prev = stop[0].seq;
  bool wrapped = false;
  uint32_t bad = 0;
  for (uint32_t k = 0; k < 65540; ++k) {
    std::vector<Msg> m = b.sendBytes(ping);
    if (m.size() != 1 || m[0].seq != static_cast<uint16_t>(prev + 1)) ++bad;
    if (!m.empty()) {
      if (m[0].seq == 0 && prev == 65535) wrapped = true;
      prev = m[0].seq;
    }
  }
  CHECK(bad == 0);
  CHECK(wrapped);
}

TEST_CASE("samples: a frame that does not fit the TX buffer is dropped and counted") {
  Bench b;
  b.send(MsgType::Start, 1);
  b.run(3 * kT80);
  b.hal.tx_free = 20;  // a 4-channel SAMPLE needs 28 bytes
  std::vector<Msg> out = b.run(5 * kT80);
  CHECK(out.empty());
  b.hal.tx_free = 1000;
  out = b.run(kT80);
  REQUIRE(out.size() == 1);
  const Msg s = b.stats();
  CHECK(s.stat(kTxOverruns) == 5);
  // The dropped frames used their sequence numbers: the host sees the gap.
  CHECK(s.seq == out[0].seq + 1);
  // Answers are never dropped: with too little room for the longest answer (INFO + ACK) a
  // command waits in the receive buffer, and is answered once the room is back.
  b.send(MsgType::Stop, 4);
  b.hal.tx_free = 8;
  b.hal.rx.clear();
  const Bytes ping = command(0x01, 5);
  b.hal.rx.insert(b.hal.rx.end(), ping.begin(), ping.end());
  for (int k = 0; k < 20; ++k) b.dev.poll();
  CHECK(b.hal.tx.empty());
  CHECK(b.hal.rx.size() == ping.size());  // not consumed
  b.hal.tx_free = 1000;
  for (int k = 0; k < 3; ++k) b.dev.poll();
  out = b.collect();
  REQUIRE(out.size() == 1);
  CHECK(out[0].is(MsgType::Ack));
  CHECK(b.stats().stat(kTxOverruns) == 5);
}

TEST_CASE("timeouts: a dead chip is flagged, the others stream at the full rate") {
  Bench b;
  for (int i = 0; i < 4; ++i) b.hal.value[i] = i + 1;
  b.hal.alive = 0b1011;  // channel 2 missing from boot
  b.send(MsgType::Start, 1);
  std::vector<Msg> samples = only(b.run(1000000), MsgType::Sample);
  // The first read waits for channel 2 through the boot settling (5.5 periods), then gives
  // up; from then on it follows the live chips.
  REQUIRE(samples.size() == 76);
  CHECK(samples[0].timestamp() >= 5 * kT80 + kT80 / 2);  // seen by a poll every 100 us
  CHECK(samples[0].timestamp() <= 5 * kT80 + kT80 / 2 + 100);
  CHECK(samples[1].timestamp() == 6 * kT80);
  for (const Msg& s : samples) {
    CHECK(s.timeoutMask() == 0b0100);
    CHECK(s.value(0) == 1);
    CHECK(s.value(1) == 2);
    CHECK(s.value(2) == 0);
    CHECK(s.value(3) == 4);
  }
  for (size_t k = 2; k < samples.size(); ++k) {
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() == kT80);
  }
  CHECK(b.stats().stat(kReadTimeouts) == b.hal.pulses.size());
  CHECK(b.dev.liveMask() == 0b1011);
}

TEST_CASE("timeouts: a chip that comes back has its first reading discarded") {
  Bench b;
  for (int i = 0; i < 4; ++i) b.hal.value[i] = 10 * (i + 1);
  b.send(MsgType::Start, 1);
  b.run(5 * kT80);
  b.hal.alive = 0b1110;  // channel 0 sleeps (power-down, brown-out)
  std::vector<Msg> out = only(b.run(5 * kT80), MsgType::Sample);
  CHECK(out.back().timeoutMask() == 0b0001);
  CHECK(b.dev.staleMask() == 0b0001);
  b.hal.alive = 0b1111;  // back
  out = only(b.run(3 * kT80), MsgType::Sample);
  REQUIRE(out.size() == 3);
  CHECK(out[0].timeoutMask() == 0b0001);  // first reading after the return: discarded
  CHECK(out[0].value(0) == 0);
  CHECK(out[1].timeoutMask() == 0);
  CHECK(out[1].value(0) == 10);
  CHECK(out[2].timeoutMask() == 0);
}

TEST_CASE("timeouts: with every chip gone, all-timeout samples every 1.5 periods") {
  Bench b;
  b.send(MsgType::Start, 1);
  b.run(3 * kT80);
  b.hal.alive = 0;
  std::vector<Msg> samples = only(b.run(20 * kT80), MsgType::Sample);
  REQUIRE(samples.size() >= 10);
  for (size_t k = 2; k < samples.size(); ++k) {
    CHECK(samples[k].timeoutMask() == 0xF);
    // 1.5 periods after the previous read, seen by a poll every 100 us.
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() >= kT80 + kT80 / 2);
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() <= kT80 + kT80 / 2 + 100);
  }
}

TEST_CASE("timeouts: the wait gives up 1.5 periods after the previous ready time") {
  Bench b;
  b.run(6 * kT80);  // past the settling after boot
  b.hal.auto_convert = false;
  const uint32_t t0 = b.hal.read_time.back();
  b.hal.ready = 0b0111;  // channel 3 never becomes ready
  b.run(kT80 + kT80 / 2 - 300);
  CHECK(b.hal.read_time.back() == t0);  // still waiting
  b.run(400);
  REQUIRE(b.hal.read_time.back() != t0);
  CHECK(b.hal.read_time.back() - t0 >= kT80 + kT80 / 2);
  CHECK(b.hal.read_time.back() - t0 < kT80 + kT80 / 2 + 200);
  CHECK(b.stats().stat(kReadTimeouts) == 1);
}

TEST_CASE("timeouts: a DOUT stuck low does not flood the link") {
  Bench b;
  b.hal.auto_convert = false;
  b.hal.stuck_low = 0xF;
  b.send(MsgType::Start, 1);
  std::vector<Msg> samples = only(b.run(1000000, 50), MsgType::Sample);
  // Reads at most every 3/4 period instead of on every loop.
  CHECK(samples.size() <= 1000000 / (kT80 * 3 / 4) + 1);
  CHECK(samples.size() >= 80);
}

TEST_CASE("device clock wrap: timeouts, stats and streaming go on across 2^32 us") {
  Bench b(4, 0, 1, 0xFFFFFFFFu - 500000);
  b.send(MsgType::Start, 1);
  std::vector<Msg> out = b.run(2000000);
  std::vector<Msg> samples = only(out, MsgType::Sample);
  CHECK(samples.size() == 160);
  for (size_t k = 1; k < samples.size(); ++k) {
    CHECK(samples[k].timestamp() - samples[k - 1].timestamp() == kT80);
    CHECK(samples[k].timeoutMask() == 0);
  }
  CHECK(only(out, MsgType::Stats).size() == 2);
}

TEST_CASE("16 channels: all masks and values") {
  Bench b(16);
  for (int i = 0; i < 16; ++i) b.hal.value[i] = -1000 * i;
  b.hal.alive = 0x7FFF;  // channel 15 dead
  b.send(MsgType::Start, 1);
  std::vector<Msg> samples = only(b.run(8 * kT80), MsgType::Sample);
  REQUIRE(!samples.empty());
  const Msg& s = samples.back();
  CHECK(s.channels() == 16);
  CHECK(s.p.size() == 9 + 48);
  CHECK(s.timeoutMask() == 0x8000);
  CHECK(s.value(14) == -14000);
  std::vector<Msg> m = b.send(MsgType::Tare, 2, tarePayload(0x8000, 1));
  CHECK(m.empty());
  m = only(b.run(3 * kT80), MsgType::Nack);
  REQUIRE(m.size() == 1);
  checkNack(m[0], 2, 0x05, NackError::ChipTimeout);
}

TEST_CASE("loop time: longest interval between two polls") {
  Bench b;
  b.run(1000, 10);
  b.hal.now += 777;
  b.dev.poll();
  CHECK(b.stats().stat(kLongestLoop) == 777);
}

TEST_CASE("pulses: 25 / 26 / 27 for gain 128 / 32 / 64") {
  CHECK(ftc::pulsesForGain(128) == 25);
  CHECK(ftc::pulsesForGain(32) == 26);
  CHECK(ftc::pulsesForGain(64) == 27);
  CHECK(ftc::pulsesForGain(1) == 0);
}
