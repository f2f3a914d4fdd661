// The few things the device logic needs from the board. The sketch implements them with
// registers and Serial on the Uno; the native tests implement them with a scripted fake.
#ifndef FINGERTIP_CORE_HAL_H
#define FINGERTIP_CORE_HAL_H

#include <stddef.h>
#include <stdint.h>

namespace ftc {

class Hal {
 public:
  // Device clock in microseconds (micros() on the Uno: 4 us steps, wraps every 71.6 min).
  virtual uint32_t nowUs() = 0;

  // Bit i set = channel i's DOUT is low (the chip has a conversion ready). Never blocks.
  virtual uint16_t readyMask() = 0;

  // One read of every chip on the shared SCK: 24 data pulses then pulses - 24 gain pulses
  // (pulses is 25, 26 or 27). raw[i] gets channel i's 24 bits as sampled (MSB first, bits
  // 24..31 zero) for every channel of the build; the caller ignores the channels that were
  // not ready. Must keep SCK high well under 60 us per pulse.
  virtual void readChips(uint8_t pulses, uint32_t* raw) = 0;

  // on = false: SCK high and held (every HX711 powers down after 60 us);
  // on = true: SCK low (the chips power up, reset to gain 128 and settle for 4 periods).
  virtual void setPower(bool on) = 0;

  // RATE pin: true = high = 80 SPS, false = low = 10 SPS.
  virtual void setRate80(bool fast) = 0;

  // Next received UART byte, or -1 if none is waiting.
  virtual int16_t rxByte() = 0;

  // Free room in the UART transmit buffer, in bytes; txWrite never gets more than this, so
  // it never blocks.
  virtual uint16_t txFree() = 0;
  virtual void txWrite(const uint8_t* data, uint8_t len) = 0;

 protected:
  // Not deleted through this interface: no virtual destructor (it would pull operator delete
  // into the AVR build).
  ~Hal() {}
};

}  // namespace ftc

#endif  // FINGERTIP_CORE_HAL_H
