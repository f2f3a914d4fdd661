#include <Arduino.h>

#include "pins.h"
#include "uno_hal.h"

#if defined(SERIAL_TX_BUFFER_SIZE) && SERIAL_TX_BUFFER_SIZE < 128
#error "build with -DSERIAL_TX_BUFFER_SIZE=128: a 16-channel SAMPLE + STATS need more than 64 B"
#endif

uint32_t UnoHal::nowUs() { return micros(); }

int16_t UnoHal::rxByte() { return static_cast<int16_t>(Serial.read()); }

uint16_t UnoHal::txFree() {
  const int n = Serial.availableForWrite();
  return n > 0 ? static_cast<uint16_t>(n) : 0;
}

void UnoHal::txWrite(const uint8_t* data, uint8_t len) { Serial.write(data, len); }

#ifndef FT_READ_SEQUENTIAL_DIGITALREAD
// ---------------------------------------------------------------------------------------------
// Register access: all DOUT pins sampled in parallel, one port read per clock.

void UnoHal::begin() {
  // SCK: drive high first, then make it an output, so it never glitches low.
  FT_SCK_PORT |= _BV(FT_SCK_BIT);
  FT_SCK_DDR |= _BV(FT_SCK_BIT);
  FT_RATE_PORT |= _BV(FT_RATE_BIT);  // 80 SPS, the boot default
  FT_RATE_DDR |= _BV(FT_RATE_BIT);
  // DOUT: inputs with pull-ups.
  DDRD &= static_cast<uint8_t>(~FT_DOUT_D_MASK);
  PORTD |= FT_DOUT_D_MASK;
#if FT_CH_ON_C > 0
  DDRC &= static_cast<uint8_t>(~FT_DOUT_C_MASK);
  PORTC |= FT_DOUT_C_MASK;
#endif
#if FT_CH_ON_B > 0
  DDRB &= static_cast<uint8_t>(~FT_DOUT_B_MASK);
  PORTB |= FT_DOUT_B_MASK;
#endif
  Serial.begin(FT_UART_BAUD);
}

uint16_t UnoHal::readyMask() {
  uint16_t low = static_cast<uint8_t>(~PIND & FT_DOUT_D_MASK) >> FT_DOUT_D_SHIFT;
#if FT_CH_ON_C > 0
  low |= static_cast<uint16_t>(static_cast<uint8_t>(~PINC & FT_DOUT_C_MASK)) << FT_DOUT_C_FIRST;
#endif
#if FT_CH_ON_B > 0
  low |= static_cast<uint16_t>(static_cast<uint8_t>(~PINB & FT_DOUT_B_MASK)) << FT_DOUT_B_FIRST;
#endif
  return low;
}

// t2 of the datasheet: DOUT is valid at most 0.1 us (1.6 cycles) after the SCK rising edge,
// and the PIN synchroniser adds up to 1.5 cycles: four NOPs between the SBI and the first IN.
// SCK then stays high for 4 + 1..3 (IN) + 2 (CBI) cycles = 7..9 cycles = 0.44..0.56 us:
// above the 0.2 us minimum and far below the 60 us power-down.
#define FT_T2_WAIT() __asm__ __volatile__("nop\n\tnop\n\tnop\n\tnop\n\t" ::)

void UnoHal::readChips(uint8_t pulses, uint32_t* raw) {
  // One snapshot of each DOUT port per data bit; transposed into words afterwards, with
  // interrupts enabled.
  uint8_t snap_d[24];
#if FT_CH_ON_C > 0
  uint8_t snap_c[24];
#endif
#if FT_CH_ON_B > 0
  uint8_t snap_b[24];
#endif
  for (uint8_t i = 0; i < 24; ++i) {
    // Interrupts are masked only while SCK is high: an ISR there could stretch the pulse
    // toward the 60 us power-down; during SCK low they run freely (UART, timer 0).
    const uint8_t sreg = SREG;
    cli();
    FT_SCK_PORT |= _BV(FT_SCK_BIT);  // SBI: rising edge, the chips shift out the next bit
    FT_T2_WAIT();
    snap_d[i] = PIND;
#if FT_CH_ON_C > 0
    snap_c[i] = PINC;
#endif
#if FT_CH_ON_B > 0
    snap_b[i] = PINB;
#endif
    FT_SCK_PORT &= static_cast<uint8_t>(~_BV(FT_SCK_BIT));  // CBI
    SREG = sreg;
  }
  // Pulses 25..27 select the gain of the next conversion.
  for (uint8_t i = 24; i < pulses; ++i) {
    const uint8_t sreg = SREG;
    cli();
    FT_SCK_PORT |= _BV(FT_SCK_BIT);
    FT_T2_WAIT();
    FT_SCK_PORT &= static_cast<uint8_t>(~_BV(FT_SCK_BIT));
    SREG = sreg;
  }
  for (uint8_t ch = 0; ch < FT_CHANNELS; ++ch) {
    const uint8_t* snap = snap_d;
    uint8_t mask;
    if (ch < FT_DOUT_C_FIRST) {
      mask = static_cast<uint8_t>(1u << (ch + FT_DOUT_D_SHIFT));
    }
#if FT_CH_ON_C > 0
    else if (ch < FT_DOUT_B_FIRST) {
      snap = snap_c;
      mask = static_cast<uint8_t>(1u << (ch - FT_DOUT_C_FIRST));
    }
#endif
#if FT_CH_ON_B > 0
    else {
      snap = snap_b;
      mask = static_cast<uint8_t>(1u << (ch - FT_DOUT_B_FIRST));
    }
#else
    else {
      mask = 0;  // unreachable: no channel sits on port B in this build
    }
#endif
    uint32_t word = 0;
    for (uint8_t k = 0; k < 24; k += 8) {  // byte by byte: 8-bit shifts are cheap on AVR
      uint8_t byte = 0;
      for (uint8_t j = 0; j < 8; ++j) {
        byte = static_cast<uint8_t>(byte << 1);
        if (snap[k + j] & mask) byte |= 1;
      }
      word = (word << 8) | byte;
    }
    raw[ch] = word;
  }
}

void UnoHal::setPower(bool on) {
  if (on) {
    FT_SCK_PORT &= static_cast<uint8_t>(~_BV(FT_SCK_BIT));
  } else {
    FT_SCK_PORT |= _BV(FT_SCK_BIT);
  }
}

void UnoHal::setRate80(bool fast) {
  if (fast) {
    FT_RATE_PORT |= _BV(FT_RATE_BIT);
  } else {
    FT_RATE_PORT &= static_cast<uint8_t>(~_BV(FT_RATE_BIT));
  }
}

#else  // FT_READ_SEQUENTIAL_DIGITALREAD
// ---------------------------------------------------------------------------------------------
// Benchmark baseline: what common Arduino HX711 code does on a shared SCK (HX711MULTI style):
// digitalWrite for SCK, then each DOUT read one after another with digitalRead while SCK is
// high, no interrupt masking. Same protocol and device logic; only this layer differs.

namespace {
const uint8_t kDoutPins[16] = FT_DOUT_ARDUINO_PINS;
}

void UnoHal::begin() {
  digitalWrite(FT_SCK_ARDUINO_PIN, HIGH);
  pinMode(FT_SCK_ARDUINO_PIN, OUTPUT);
  digitalWrite(FT_RATE_ARDUINO_PIN, HIGH);
  pinMode(FT_RATE_ARDUINO_PIN, OUTPUT);
  for (uint8_t ch = 0; ch < FT_CHANNELS; ++ch) {
    pinMode(kDoutPins[ch], INPUT_PULLUP);
  }
  Serial.begin(FT_UART_BAUD);
}

uint16_t UnoHal::readyMask() {
  uint16_t low = 0;
  for (uint8_t ch = 0; ch < FT_CHANNELS; ++ch) {
    if (digitalRead(kDoutPins[ch]) == LOW) low |= static_cast<uint16_t>(1u << ch);
  }
  return low;
}

void UnoHal::readChips(uint8_t pulses, uint32_t* raw) {
  for (uint8_t ch = 0; ch < FT_CHANNELS; ++ch) {
    raw[ch] = 0;
  }
  for (uint8_t i = 0; i < 24; ++i) {
    digitalWrite(FT_SCK_ARDUINO_PIN, HIGH);
    for (uint8_t ch = 0; ch < FT_CHANNELS; ++ch) {
      raw[ch] = (raw[ch] << 1) | (digitalRead(kDoutPins[ch]) == HIGH ? 1u : 0u);
    }
    digitalWrite(FT_SCK_ARDUINO_PIN, LOW);
  }
  for (uint8_t i = 24; i < pulses; ++i) {
    digitalWrite(FT_SCK_ARDUINO_PIN, HIGH);
    digitalWrite(FT_SCK_ARDUINO_PIN, LOW);
  }
}

void UnoHal::setPower(bool on) { digitalWrite(FT_SCK_ARDUINO_PIN, on ? LOW : HIGH); }

void UnoHal::setRate80(bool fast) { digitalWrite(FT_RATE_ARDUINO_PIN, fast ? HIGH : LOW); }

#endif  // FT_READ_SEQUENTIAL_DIGITALREAD
