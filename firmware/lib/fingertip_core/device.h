// The fingertip device: commands, streaming, tare, statistics and chip bookkeeping of
// docs/protocol.md sections 5 and 6, without Arduino. The board is reached only through Hal.
#ifndef FINGERTIP_CORE_DEVICE_H
#define FINGERTIP_CORE_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "fingertip_protocol.h"
#include "hal.h"

namespace ftc {

// Firmware version reported in INFO and in the boot LOG.
const uint8_t kFwMajor = 0;
const uint8_t kFwMinor = 1;
const uint8_t kFwPatch = 0;

// Build defaults (section 6: a device boots at 80 SPS, decimation 1, gain 128).
const uint8_t kDefaultRate = 80;
const uint8_t kDefaultDecimation = 1;
const uint8_t kDefaultGain = 128;

// HX711 timing (datasheet): output settling after power-up, a RATE change or a gain change
// takes 4 conversion periods, during which DOUT stays high.
const uint8_t kSettlePeriods = 4;
const uint32_t kStatsIntervalUs = 1000000UL;

// Per-channel state; the caller owns an array of `channels` of them, so a 4-channel build
// does not pay RAM for 16.
struct ChannelState {
  int32_t offset;    // tare offset, int24 range
  int32_t tare_sum;  // sum of raw readings during a tare: 256 x int24 fits int32
};

struct DeviceConfig {
  uint8_t channels;     // 1..16
  uint32_t build_id;    // first 8 hex digits of the git commit, or 0
  uint8_t reset_cause;  // MCUSR at boot
};

// Number of SCK pulses for a gain (25: 128 A, 26: 32 B, 27: 64 A); 0 for an invalid gain.
uint8_t pulsesForGain(uint8_t gain);

class Device {
 public:
  Device(Hal& hal, ChannelState* channels, const DeviceConfig& config);

  // Power-on: powers the chips up (the caller has held SCK high for > 60 us before, or the
  // board just got power), sets the RATE pin, sends 0x00, INFO (reason 1, seq 0) and LOG.
  void boot();

  // One main-loop iteration: at most one received command, then the chips (non-blocking
  // ready check, read, tare, SAMPLE), then the 1 Hz STATS. Never waits.
  void poll();

  // --- observers (INFO fields, tests) ------------------------------------------------------
  uint8_t channels() const { return channels_; }
  bool streaming() const { return streaming_; }
  bool powered() const { return powered_; }
  bool tareActive() const { return tare_active_; }
  uint8_t rateSps() const { return rate_; }
  uint8_t decimation() const { return decimation_; }
  uint8_t gain() const { return gain_; }
  int32_t offset(uint8_t ch) const { return ch_[ch].offset; }
  uint8_t flags() const;
  uint16_t tareMask() const;  // channels with a non-zero offset
  // Channels the next read waits for, and channels whose next reading is discarded.
  uint16_t liveMask() const { return live_; }
  uint16_t staleMask() const { return stale_; }
  // When the current wait for the chips gives up (device time).
  uint32_t deadlineUs() const { return deadline_; }
  // When the next STATS is due while streaming (device time).
  uint32_t nextStatsUs() const { return next_stats_us_; }
  // For a board simulated on a PC that calls poll() only when something is due: the time
  // since the last poll was idle (a real loop would have spun through it), not one loop.
  void forgetLoopStart() { loop_started_ = false; }
  ftp::Stats stats(uint32_t timestamp_us) const;
  ftp::Encoder& encoder() { return enc_; }

 private:
  // Commands.
  void serviceRx();
  uint16_t replyRoom() const;
  void execute(const ftp::Command& c);
  void startTare(const ftp::Command& c);
  void setTareOffsets(const ftp::Command& c);
  void setRate(const ftp::Command& c);
  void setPower(bool on, uint32_t now);
  void resetCounters();

  // Chips.
  void serviceChips();
  void processReading(uint32_t stamp, uint16_t ready, const uint32_t* raw);
  void finishTare(bool ok);
  void expectSettling(uint32_t now);
  uint32_t periodUs() const { return rate_ == 80 ? 12500UL : 100000UL; }
  uint16_t allMask() const;

  // Output. Each returns whether the frame went into the UART buffer.
  bool transmit(size_t n);
  bool sendAck(uint16_t request_id, ftp::MsgType type);
  bool sendNack(uint16_t request_id, ftp::MsgType type, ftp::NackError error);
  bool sendInfo(uint8_t reason);
  bool sendStats(uint32_t now);
  bool sendLog(ftp::LogLevel level, const char* text, uint8_t len);

  Hal& hal_;
  ChannelState* ch_;
  const uint8_t channels_;
  const uint32_t build_id_;
  const uint8_t reset_cause_;

  ftp::Encoder enc_;
  ftp::CommandReceiver rx_;
  uint8_t tx_[ftp::kMaxWire];

  // Settings.
  uint8_t rate_;
  uint8_t decimation_;
  uint8_t gain_;
  bool streaming_;
  bool powered_;

  // Chip bookkeeping.
  uint8_t chip_gain_;      // gain the chips convert with now (128 after a power-up)
  uint8_t dec_count_;      // conversions kept since the last decimated one
  uint16_t live_;          // channels that gave a valid reading last time: the read waits for them
  uint16_t stale_;         // channels that timed out: their next reading is discarded
  bool have_go_;           // the last read was triggered by the chips being ready...
  uint32_t last_go_us_;    // ...at this time
  uint32_t deadline_;      // the wait for the live channels gives up here
  bool settling_;          // settle_until_ is meaningful
  uint32_t settle_until_;  // chips settling after power-up, RATE or gain change: no timeout before

  // Tare in progress.
  bool tare_active_;
  uint16_t tare_request_;
  uint16_t tare_mask_;
  uint16_t tare_samples_;
  uint16_t tare_taken_;

  // STATS.
  uint32_t next_stats_us_;
  uint32_t frames_sent_;
  uint32_t read_timeouts_;
  uint32_t saturations_;
  uint32_t command_errors_;
  uint32_t tx_overruns_;
  uint32_t longest_loop_us_;
  bool loop_started_;
  uint32_t loop_start_us_;
};

}  // namespace ftc

#endif  // FINGERTIP_CORE_DEVICE_H
