// A simulated board for the device logic on a PC: the Hal of lib/fingertip_core with a
// settable clock, HX711 chips that convert on their own schedule, and UART byte queues.
// The virtual fingertip (host/fingertip/sim/device/virtual_firmware.py) drives lib/fingertip_core
// through it, so the same C++ runs on the Uno, in simavr and on the host.
#ifndef FINGERTIP_HOSTLIB_SIM_BOARD_H
#define FINGERTIP_HOSTLIB_SIM_BOARD_H

#include <stddef.h>
#include <stdint.h>

#include <vector>

#include "fingertip_core.h"

namespace fth {

// Each chip's input in counts at gain 128 at device time t_us (before clipping); returns 0,
// or non-zero when the inputs could not be had (the caller's error, reported back to it).
typedef int (*InputsFn)(void* ctx, uint64_t t_us, double* inputs, uint8_t n);

// What a chip does; one value per chip, so a new fault is one more case in readyMask and
// readChips.
enum class ChipMode : uint8_t {
  Ok = 0,
  Absent = 1,  // never ready (missing, unpowered or broken chip): DOUT stays high
};

struct Chip {
  ChipMode mode = ChipMode::Ok;
  bool ready = false;  // a conversion waits to be read: DOUT low
  uint8_t gain = 128;  // gain of the current conversion (set by the previous read's pulses)
};

// Why a read could not give the chips' values.
enum BoardError : int {
  kBoardOk = 0,
  kBoardInputsFailed = -1,  // the inputs callback reported an error
  kBoardBadInput = -2,      // an input was NaN
};

class SimBoard : public ftc::Hal {
 public:
  explicit SimBoard(uint8_t channels);

  // --- clock: device time in microseconds, 64 bits (the Hal sees micros(): 4 us steps,
  // wrapping at 2^32, as on the Uno) ---------------------------------------------------------
  uint64_t now() const { return now_; }
  // Moves the clock to t (never backwards); conversions due by then become ready.
  void setNow(uint64_t t);
  static uint32_t micros(uint64_t t) { return static_cast<uint32_t>(t - t % 4u); }

  // --- chips ---------------------------------------------------------------------------------
  bool powered() const { return powered_; }
  uint32_t periodUs() const { return rate80_ ? 12500u : 100000u; }
  uint64_t nextConversion() const { return next_conv_; }  // meaningful while powered
  void setMode(uint8_t channel, ChipMode mode);
  ChipMode mode(uint8_t channel) const { return chips_[channel].mode; }
  void setInputs(InputsFn fn, void* ctx) {
    inputs_ = fn;
    inputs_ctx_ = ctx;
  }
  InputsFn inputs(void** ctx) const {
    *ctx = inputs_ctx_;
    return inputs_;
  }
  // First error of a read since the last call (BoardError), then cleared.
  int takeError();

  // --- UART ----------------------------------------------------------------------------------
  void pushRx(const uint8_t* data, size_t len);
  bool rxPending() const { return rx_pos_ < rx_.size(); }
  const std::vector<uint8_t>& tx() const { return tx_; }
  void clearTx() { tx_.clear(); }

  // --- ftc::Hal ------------------------------------------------------------------------------
  uint32_t nowUs() override { return micros(now_); }
  uint16_t readyMask() override;
  void readChips(uint8_t pulses, uint32_t* raw) override;
  void setPower(bool on) override;
  void setRate80(bool fast) override;
  int16_t rxByte() override;
  // The host takes every byte at once: the buffer never fills (no tx_overruns).
  uint16_t txFree() override { return 0xFFFFu; }
  void txWrite(const uint8_t* data, uint8_t len) override;

 private:
  void restartConversions();  // after power-up or a RATE change: 4 periods of settling

  const uint8_t channels_;
  uint64_t now_;
  bool powered_;
  bool rate80_;
  uint64_t next_conv_;
  Chip chips_[ftp::kMaxChannels];
  InputsFn inputs_;
  void* inputs_ctx_;
  int error_;
  std::vector<uint8_t> rx_;
  size_t rx_pos_;
  std::vector<uint8_t> tx_;
};

}  // namespace fth

#endif  // FINGERTIP_HOSTLIB_SIM_BOARD_H
