#include "device.h"

#include <string.h>

namespace ftc {

namespace {

// Signed wrap-around comparison of two u32 device times: true if a is at or after b.
// Valid while they are less than half a wrap (35.8 min) apart.
inline bool timeReached(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b) >= 0; }

inline bool bit(uint16_t mask, uint8_t i) { return ((mask >> i) & 1u) != 0; }

// Average of n readings, rounded half away from zero. The sum of at most 256 int24 values fits
// int32 (down to exactly INT32_MIN), so the magnitude is taken as u32 to stay defined.
int32_t roundedAverage(int32_t sum, uint16_t n) {
  const bool neg = sum < 0;
  const uint32_t mag = neg ? 0u - static_cast<uint32_t>(sum) : static_cast<uint32_t>(sum);
  const uint32_t q = (mag + n / 2u) / n;  // <= 2^23: the result is always in int24 range
  return neg ? -static_cast<int32_t>(q) : static_cast<int32_t>(q);
}

// Appends the decimal digits of v; returns the new end.
char* appendU8(char* p, uint8_t v) {
  if (v >= 100) {
    *p++ = static_cast<char>('0' + v / 100);
  }
  if (v >= 10) {
    *p++ = static_cast<char>('0' + (v / 10) % 10);
  }
  *p++ = static_cast<char>('0' + v % 10);
  return p;
}

char* appendStr(char* p, const char* s) {
  while (*s != '\0') {
    *p++ = *s++;
  }
  return p;
}

}  // namespace

uint8_t pulsesForGain(uint8_t gain) {
  switch (gain) {
    case 128:
      return 25;
    case 32:
      return 26;
    case 64:
      return 27;
    default:
      return 0;
  }
}

Device::Device(Hal& hal, ChannelState* channels, const DeviceConfig& config)
    : hal_(hal),
      ch_(channels),
      channels_(config.channels),
      build_id_(config.build_id),
      reset_cause_(config.reset_cause),
      rate_(kDefaultRate),
      decimation_(kDefaultDecimation),
      gain_(kDefaultGain),
      streaming_(false),
      powered_(false),
      chip_gain_(kDefaultGain),
      dec_count_(0),
      live_(0),
      stale_(0),
      have_go_(false),
      last_go_us_(0),
      deadline_(0),
      settling_(false),
      settle_until_(0),
      tare_active_(false),
      tare_request_(0),
      tare_mask_(0),
      tare_samples_(0),
      tare_taken_(0),
      next_stats_us_(0),
      frames_sent_(0),
      read_timeouts_(0),
      saturations_(0),
      command_errors_(0),
      tx_overruns_(0),
      longest_loop_us_(0),
      loop_started_(false),
      loop_start_us_(0) {
  memset(tx_, 0, sizeof(tx_));
  memset(ch_, 0, sizeof(ChannelState) * channels_);
}

uint16_t Device::allMask() const {
  return channels_ >= ftp::kMaxChannels ? 0xFFFFu
                                        : static_cast<uint16_t>((1u << channels_) - 1u);
}

uint8_t Device::flags() const {
  uint8_t f = 0;
  if (streaming_) f |= ftp::kFlagStreaming;
  if (!powered_) f |= ftp::kFlagPoweredDown;
  if (tare_active_) f |= ftp::kFlagTareInProgress;
  return f;
}

uint16_t Device::tareMask() const {
  uint16_t m = 0;
  for (uint8_t i = 0; i < channels_; ++i) {
    if (ch_[i].offset != 0) m = static_cast<uint16_t>(m | (1u << i));
  }
  return m;
}

ftp::Stats Device::stats(uint32_t timestamp_us) const {
  const ftp::RxCounters& rc = rx_.counters();
  ftp::Stats s;
  s.timestamp_us = timestamp_us;
  s.frames_sent = frames_sent_;
  s.read_timeouts = read_timeouts_;
  s.saturations = saturations_;
  s.command_errors = command_errors_;
  s.rx_overflows = rc.overflows;
  s.rx_crc_errors = rc.crc_errors;
  s.rx_framing_errors = rc.framing_errors;
  s.tx_overruns = tx_overruns_;
  s.longest_loop_us = longest_loop_us_;
  return s;
}

// --- boot and main loop ---------------------------------------------------------------------

void Device::boot() {
  rate_ = kDefaultRate;
  decimation_ = kDefaultDecimation;
  gain_ = kDefaultGain;
  streaming_ = false;
  tare_active_ = false;
  memset(ch_, 0, sizeof(ChannelState) * channels_);
  enc_.setSeq(0);
  rx_.clear();
  rx_.resetCounters();
  frames_sent_ = read_timeouts_ = saturations_ = command_errors_ = tx_overruns_ = 0;
  longest_loop_us_ = 0;
  loop_started_ = false;

  hal_.setRate80(true);
  powered_ = false;
  setPower(true, hal_.nowUs());

  // A lone delimiter ends whatever partial frame the host's receiver holds.
  if (hal_.txFree() >= 1) {
    const uint8_t zero = 0;
    hal_.txWrite(&zero, 1);
  }
  sendInfo(ftp::kInfoReasonBoot);
  char text[40];
  char* p = appendStr(text, "fingertip fw ");
  p = appendU8(p, kFwMajor);
  *p++ = '.';
  p = appendU8(p, kFwMinor);
  *p++ = '.';
  p = appendU8(p, kFwPatch);
  p = appendStr(p, ", ");
  p = appendU8(p, channels_);
  p = appendStr(p, " channels");
  sendLog(ftp::LogLevel::Info, text, static_cast<uint8_t>(p - text));
}

void Device::poll() {
  const uint32_t now = hal_.nowUs();
  // Loop time = interval between two starts: it includes what the sketch does between calls.
  if (loop_started_) {
    const uint32_t d = now - loop_start_us_;
    if (d > longest_loop_us_) longest_loop_us_ = d;
  }
  loop_started_ = true;
  loop_start_us_ = now;

  serviceRx();
  serviceChips();
  if (streaming_) {
    const uint32_t t = hal_.nowUs();
    if (timeReached(t, next_stats_us_)) {
      sendStats(t);
      next_stats_us_ += kStatsIntervalUs;
      if (timeReached(t, next_stats_us_)) {
        next_stats_us_ = t + kStatsIntervalUs;  // fell behind by a whole second: resync
      }
    }
  }
}

// --- commands -------------------------------------------------------------------------------

void Device::serviceRx() {
  // Bytes up to and including one delimiter: one command per loop iteration at most, so the
  // chips are checked between commands. A command is taken only when its longest answer
  // (INFO then ACK) fits in the transmit buffer: answers are never dropped, the command
  // waits in the UART's receive buffer instead (the host waits for its answer anyway).
  if (hal_.txFree() < replyRoom()) return;
  for (;;) {
    const int16_t b = hal_.rxByte();
    if (b < 0) return;
    ftp::RxResult r;
    if (!rx_.feed(static_cast<uint8_t>(b), r)) continue;
    if (r.error == ftp::RxError::None) {
      execute(r.command);
    } else if (r.nack != ftp::NackError::None) {
      // Intact but malformed (unknown type, bad length, bad argument): answered.
      sendNack(r.command.request_id, r.command.type, r.nack);
    }
    // Garbled frames (COBS, CRC, too short, too long) are only counted by the receiver.
    return;
  }
}

uint16_t Device::replyRoom() const {
  // INFO frame 23 + 3 x channels bytes, ACK frame 8 bytes; each + 1 COBS + 1 delimiter.
  return static_cast<uint16_t>(23u + 3u * channels_ + 2u + 8u + 2u);
}

void Device::execute(const ftp::Command& c) {
  const uint32_t now = hal_.nowUs();
  switch (c.type) {
    case ftp::MsgType::Ping:
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::GetInfo:
      sendInfo(ftp::kInfoReasonRequest);
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::GetStats:
      sendStats(now);
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::Start:
      if (!powered_) {
        sendNack(c.request_id, c.type, ftp::NackError::PoweredDown);
        return;
      }
      if (!streaming_) {
        streaming_ = true;
        next_stats_us_ = now + kStatsIntervalUs;
      }
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::Stop:
      streaming_ = false;
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::ResetCounters:
      resetCounters();
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::Tare:
      startTare(c);
      return;
    default:
      break;
  }
  // The rest change the chips' set-up or the offsets: they wait for a tare in progress.
  if (tare_active_) {
    sendNack(c.request_id, c.type, ftp::NackError::Busy);
    return;
  }
  switch (c.type) {
    case ftp::MsgType::SetTareOffsets:
      setTareOffsets(c);
      return;
    case ftp::MsgType::SetRate:
      setRate(c);
      return;
    case ftp::MsgType::SetGain:
      // The reading after a change still has the old gain: processReading discards it
      // (chip_gain_ != gain_). Changing back before any read discards nothing.
      gain_ = c.gain;
      sendAck(c.request_id, c.type);
      return;
    case ftp::MsgType::SetPower:
      setPower(c.on != 0, now);
      sendAck(c.request_id, c.type);
      return;
    default:
      // The receiver only passes defined commands; kept so that a new one is never silent.
      sendNack(c.request_id, c.type, ftp::NackError::UnknownCommand);
      return;
  }
}

void Device::startTare(const ftp::Command& c) {
  // The receiver has checked mask != 0 and samples <= 256.
  if (tare_active_) {
    sendNack(c.request_id, c.type, ftp::NackError::Busy);
    return;
  }
  if (!ftp::maskFitsChannels(c.channel_mask, channels_)) {
    sendNack(c.request_id, c.type, ftp::NackError::BadArgument);
    return;
  }
  if (!powered_) {
    sendNack(c.request_id, c.type, ftp::NackError::PoweredDown);
    return;
  }
  if (c.samples == 0) {
    for (uint8_t i = 0; i < channels_; ++i) {
      if (bit(c.channel_mask, i)) ch_[i].offset = 0;
    }
    sendAck(c.request_id, c.type);
    return;
  }
  tare_active_ = true;
  tare_request_ = c.request_id;
  tare_mask_ = c.channel_mask;
  tare_samples_ = c.samples;
  tare_taken_ = 0;
  for (uint8_t i = 0; i < channels_; ++i) {
    ch_[i].tare_sum = 0;
  }
}

void Device::setTareOffsets(const ftp::Command& c) {
  if (!ftp::maskFitsChannels(c.channel_mask, channels_)) {
    sendNack(c.request_id, c.type, ftp::NackError::BadArgument);
    return;
  }
  for (uint8_t i = 0; i < channels_; ++i) {
    if (bit(c.channel_mask, i)) ch_[i].offset = c.offsets[i];  // int24 from the wire
  }
  sendAck(c.request_id, c.type);
}

void Device::setRate(const ftp::Command& c) {
  if (c.rate_sps != rate_) {
    rate_ = c.rate_sps;
    hal_.setRate80(rate_ == 80);
    if (powered_) expectSettling(hal_.nowUs());
  }
  decimation_ = c.decimation;
  dec_count_ = 0;
  sendAck(c.request_id, c.type);
}

void Device::setPower(bool on, uint32_t now) {
  if (on == powered_) return;
  hal_.setPower(on);
  powered_ = on;
  if (!on) {
    streaming_ = false;  // START again after power-up (START is refused while powered down)
    return;
  }
  // The chips restart at gain 128 and settle; the first read sets our gain (and is
  // discarded if that differs, see processReading).
  chip_gain_ = 128;
  live_ = allMask();
  stale_ = 0;
  have_go_ = false;
  dec_count_ = 0;
  expectSettling(now);
}

void Device::resetCounters() {
  rx_.resetCounters();
  frames_sent_ = read_timeouts_ = saturations_ = command_errors_ = tx_overruns_ = 0;
  longest_loop_us_ = 0;
}

// --- chips ----------------------------------------------------------------------------------

void Device::expectSettling(uint32_t now) {
  const uint32_t period = periodUs();
  settling_ = true;
  settle_until_ = now + kSettlePeriods * period;
  deadline_ = settle_until_ + period + period / 2;
}

void Device::serviceChips() {
  if (!powered_) return;
  const uint16_t ready = static_cast<uint16_t>(hal_.readyMask() & allMask());
  const uint32_t now = hal_.nowUs();  // the ready time: taken before the read
  const uint32_t period = periodUs();
  // Wait for every channel that answered last time; with none alive, for any channel.
  bool go = live_ != 0 ? (ready & live_) == live_ : ready != 0;
  // A healthy HX711 cannot be ready again sooner than this after a read it triggered: the
  // guard only stops a DOUT stuck low from flooding the link.
  if (go && have_go_ && now - last_go_us_ < period - period / 4) go = false;
  if (!go && !timeReached(now, deadline_)) return;
  uint32_t raw[ftp::kMaxChannels];
  hal_.readChips(pulsesForGain(gain_), raw);
  have_go_ = go;
  last_go_us_ = now;
  processReading(now, ready, raw);
}

void Device::processReading(uint32_t stamp, uint16_t ready, const uint32_t* raw) {
  const uint32_t period = periodUs();
  const uint16_t timeouts = static_cast<uint16_t>(allMask() & ~ready);
  // A channel back from a timeout may have restarted (power-down, brown-out) at gain 128, or
  // been clocked in the middle of a read: its first reading is discarded.
  const uint16_t valid = static_cast<uint16_t>(ready & ~stale_);
  stale_ = timeouts;
  live_ = valid;
  for (uint8_t i = 0; i < channels_; ++i) {
    if (bit(timeouts, i)) {
      ++read_timeouts_;
    } else if (bit(valid, i) && ftp::isSaturatedRaw(raw[i])) {
      ++saturations_;
    }
  }

  // The pulses of this read set the gain of the next conversion. If the chips were at another
  // gain, this reading has the old one: discard it, and let the chips settle on the new one.
  bool discard = false;
  if (ready != 0 && chip_gain_ != gain_) {
    discard = true;
    chip_gain_ = gain_;
    settling_ = true;
    settle_until_ = stamp + kSettlePeriods * period;
  }
  deadline_ = stamp + period + period / 2;
  if (settling_) {
    if (timeReached(stamp, settle_until_)) {
      settling_ = false;
    } else {
      const uint32_t d = settle_until_ + period + period / 2;
      if (timeReached(d, deadline_)) deadline_ = d;
    }
  }

  const bool tare_failed = tare_active_ && (tare_mask_ & ~valid) != 0;
  bool tare_done = false;
  if (!discard && ++dec_count_ >= decimation_) {
    dec_count_ = 0;
    ftp::Sample s;
    s.timestamp_us = stamp;
    s.channels = channels_;
    s.timeout_mask = static_cast<uint16_t>(allMask() & ~valid);
    s.saturation_mask = 0;
    for (uint8_t i = 0; i < channels_; ++i) {
      s.values[i] = 0;
      if (!bit(valid, i)) continue;
      bool sat = false;
      s.values[i] = ftp::sampleValue(raw[i], ch_[i].offset, sat);
      if (sat) s.saturation_mask = static_cast<uint16_t>(s.saturation_mask | (1u << i));
    }
    if (tare_active_ && !tare_failed) {
      for (uint8_t i = 0; i < channels_; ++i) {
        if (bit(tare_mask_, i)) ch_[i].tare_sum += ftp::signExtend24(raw[i]);
      }
      tare_done = ++tare_taken_ >= tare_samples_;
    }
    // The SAMPLE of the last tare reading still has the old offsets; the ACK follows it, and
    // every SAMPLE after the ACK has the new ones.
    if (streaming_) transmit(enc_.encodeSample(s, tx_, sizeof(tx_)));
  }
  if (tare_failed) {
    finishTare(false);
  } else if (tare_done) {
    finishTare(true);
  }
}

void Device::finishTare(bool ok) {
  tare_active_ = false;
  if (!ok) {
    sendNack(tare_request_, ftp::MsgType::Tare, ftp::NackError::ChipTimeout);  // old offsets kept
    return;
  }
  for (uint8_t i = 0; i < channels_; ++i) {
    if (bit(tare_mask_, i)) ch_[i].offset = roundedAverage(ch_[i].tare_sum, tare_samples_);
  }
  sendAck(tare_request_, ftp::MsgType::Tare);
}

// --- output ---------------------------------------------------------------------------------

bool Device::transmit(size_t n) {
  if (n == 0) return false;  // the encoder refused: cannot happen with valid state
  if (hal_.txFree() < n) {
    ++tx_overruns_;  // dropped; its seq is used, so the host sees the gap
    return false;
  }
  hal_.txWrite(tx_, static_cast<uint8_t>(n));
  ++frames_sent_;
  return true;
}

bool Device::sendAck(uint16_t request_id, ftp::MsgType type) {
  return transmit(enc_.encodeAck(request_id, type, tx_, sizeof(tx_)));
}

bool Device::sendNack(uint16_t request_id, ftp::MsgType type, ftp::NackError error) {
  ++command_errors_;
  return transmit(enc_.encodeNack(request_id, type, error, tx_, sizeof(tx_)));
}

bool Device::sendInfo(uint8_t reason) {
  ftp::Info m;
  m.protocol_major = ftp::kProtocolMajor;
  m.protocol_minor = ftp::kProtocolMinor;
  m.firmware_version[0] = kFwMajor;
  m.firmware_version[1] = kFwMinor;
  m.firmware_version[2] = kFwPatch;
  m.build_id = build_id_;
  m.reason = reason;
  m.reset_cause = reset_cause_;
  m.channels = channels_;
  m.rate_sps = rate_;
  m.decimation = decimation_;
  m.gain = gain_;
  m.flags = flags();
  m.tare_mask = tareMask();
  for (uint8_t i = 0; i < ftp::kMaxChannels; ++i) {
    m.tare_offsets[i] = i < channels_ ? ch_[i].offset : 0;
  }
  return transmit(enc_.encodeInfo(m, tx_, sizeof(tx_)));
}

bool Device::sendStats(uint32_t now) {
  const ftp::Stats s = stats(now);  // frames_sent as before this frame
  return transmit(enc_.encodeStats(s, tx_, sizeof(tx_)));
}

bool Device::sendLog(ftp::LogLevel level, const char* text, uint8_t len) {
  return transmit(enc_.encodeLog(level, text, len, tx_, sizeof(tx_)));
}

}  // namespace ftc
