#include "sim_board.h"

#include <math.h>

namespace fth {

namespace {

double gainScale(uint8_t gain) {
  // Inputs are given in counts at gain 128; the chip's output scales with its gain.
  return gain == 128 ? 1.0 : gain == 64 ? 0.5 : 0.25;
}

uint8_t gainForPulses(uint8_t pulses) {
  return pulses == 26 ? 32 : pulses == 27 ? 64 : 128;
}

}  // namespace

SimBoard::SimBoard(uint8_t channels)
    : channels_(channels),
      now_(0),
      powered_(false),
      rate80_(true),
      next_conv_(0),
      inputs_(nullptr),
      inputs_ctx_(nullptr),
      error_(kBoardOk),
      rx_pos_(0) {}

void SimBoard::setNow(uint64_t t) {
  if (t > now_) now_ = t;
  if (!powered_) return;
  // The chips share SCK, the RATE pin and the crystal: one conversion clock for all.
  bool converted = false;
  while (next_conv_ <= now_) {
    next_conv_ += periodUs();
    converted = true;
  }
  if (!converted) return;
  for (uint8_t i = 0; i < channels_; ++i) {
    if (chips_[i].mode == ChipMode::Ok) chips_[i].ready = true;
  }
}

void SimBoard::setMode(uint8_t channel, ChipMode mode) {
  chips_[channel].mode = mode;
  if (mode != ChipMode::Ok) chips_[channel].ready = false;
}

int SimBoard::takeError() {
  const int e = error_;
  error_ = kBoardOk;
  return e;
}

void SimBoard::restartConversions() {
  next_conv_ = now_ + 4u * static_cast<uint64_t>(periodUs());
  for (uint8_t i = 0; i < channels_; ++i) chips_[i].ready = false;
}

uint16_t SimBoard::readyMask() {
  uint16_t m = 0;
  for (uint8_t i = 0; i < channels_; ++i) {
    if (chips_[i].ready) m = static_cast<uint16_t>(m | (1u << i));
  }
  return m;
}

void SimBoard::readChips(uint8_t pulses, uint32_t* raw) {
  const uint16_t ready = readyMask();
  double in[ftp::kMaxChannels] = {};
  // The inputs are asked for only when a chip has a conversion to give: a physics model
  // behind them is the costly part of a simulation.
  if (ready != 0 && inputs_ != nullptr && error_ == kBoardOk) {
    if (inputs_(inputs_ctx_, now_, in, channels_) != 0) error_ = kBoardInputsFailed;
  }
  for (uint8_t i = 0; i < ftp::kMaxChannels; ++i) {
    raw[i] = 0xFFFFFFu;  // a chip that is not ready leaves DOUT high (pull-up): all ones
    if (i >= channels_ || !chips_[i].ready) continue;
    Chip& c = chips_[i];
    const double x = in[i] * gainScale(c.gain);
    int32_t v;
    if (isnan(x)) {
      if (error_ == kBoardOk) error_ = kBoardBadInput;
      v = 0;
    } else if (x >= ftp::kInt24Max) {
      v = ftp::kInt24Max;
    } else if (x <= ftp::kInt24Min) {
      v = ftp::kInt24Min;
    } else {
      v = static_cast<int32_t>(nearbyint(x));  // to nearest, ties to even
    }
    raw[i] = static_cast<uint32_t>(v) & 0xFFFFFFu;
    c.ready = false;
    // Pulses 25..27 select the gain of the next conversion.
    c.gain = gainForPulses(pulses);
  }
}

void SimBoard::setPower(bool on) {
  if (on == powered_) return;
  powered_ = on;
  if (!on) {
    for (uint8_t i = 0; i < channels_; ++i) chips_[i].ready = false;
    return;
  }
  for (uint8_t i = 0; i < channels_; ++i) chips_[i].gain = 128;  // datasheet: reset to A, 128
  restartConversions();
}

void SimBoard::setRate80(bool fast) {
  if (fast == rate80_) return;
  rate80_ = fast;
  if (powered_) restartConversions();
}

void SimBoard::pushRx(const uint8_t* data, size_t len) {
  if (rx_pos_ == rx_.size()) {
    rx_.clear();
    rx_pos_ = 0;
  }
  rx_.insert(rx_.end(), data, data + len);
}

int16_t SimBoard::rxByte() {
  if (rx_pos_ >= rx_.size()) return -1;
  return rx_[rx_pos_++];
}

void SimBoard::txWrite(const uint8_t* data, uint8_t len) { tx_.insert(tx_.end(), data, data + len); }

}  // namespace fth
