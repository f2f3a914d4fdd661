// The Uno side of ftc::Hal: HX711 bus on registers (or, for the benchmark baseline, on
// digitalRead/digitalWrite), UART through Arduino's Serial, time from micros().
#ifndef FINGERTIP_UNO_HAL_H
#define FINGERTIP_UNO_HAL_H

#include <stdint.h>

#include "fingertip_core.h"

class UnoHal : public ftc::Hal {
 public:
  // Pins and UART. Leaves SCK high: the chips power down; the caller waits > 60 us and then
  // Device::boot() powers them up again, so every boot starts from a chip reset (gain 128,
  // no half-read word left over from before an MCU reset).
  void begin();

  uint32_t nowUs() override;
  uint16_t readyMask() override;
  void readChips(uint8_t pulses, uint32_t* raw) override;
  void setPower(bool on) override;
  void setRate80(bool fast) override;
  int16_t rxByte() override;
  uint16_t txFree() override;
  void txWrite(const uint8_t* data, uint8_t len) override;
};

#endif  // FINGERTIP_UNO_HAL_H
