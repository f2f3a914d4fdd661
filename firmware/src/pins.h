// Pin map of the fingertip readout board on an Arduino Uno (ATmega328P, 16 MHz), and the
// compile-time channel count. This is the one place the map is defined; the simulator
// (firmware/sim) and the readout PCB use the same one.
//
//   signal              Arduino pin   AVR pin    direction
//   SCK (all HX711s)    D12           PB4        output (high > 60 us = power down)
//   RATE (all HX711s)   D13           PB5        output (high = 80 SPS, low = 10 SPS)
//   DOUT channel 0..5   D2..D7        PD2..PD7   input, pull-up (low = conversion ready)
//   DOUT channel 6..11  A0..A5        PC0..PC5   input, pull-up
//   DOUT channel 12..15 D8..D11       PB0..PB3   input, pull-up
//   UART (protocol v1)  D0 / D1       PD0 / PD1  1000000 baud, 8N1
//
// A 4-channel build (one fingertip) uses channels 0..3 = D2..D5 = PD2..PD5; a 16-channel build
// (four fingertips) uses all of them. The pull-ups make a missing chip read "not ready", so it
// times out instead of returning noise.
#ifndef FINGERTIP_PINS_H
#define FINGERTIP_PINS_H

#include <avr/io.h>

#ifndef FT_CHANNELS
#define FT_CHANNELS 4
#endif
#if FT_CHANNELS < 1 || FT_CHANNELS > 16
#error "FT_CHANNELS must be 1..16"
#endif

#ifndef FT_BUILD_ID
#define FT_BUILD_ID 0
#endif

// The UART rate. At 16 MHz with U2X (Arduino's default) 115200 is 117647 (+2.1 %);
// 250000, 500000 and 1000000 are exact. 1 Mbaud cuts a 4-channel frame's time on the wire
// from 2.4 to 0.28 ms (docs/benchmarks.md, latency budget); the host tries 1 Mbaud, then
// 115200. Override with -DFT_UART_BAUD=... (benchmarks build the others).
#ifndef FT_UART_BAUD
#define FT_UART_BAUD 1000000UL
#endif

// SCK and RATE: port B.
#define FT_SCK_ARDUINO_PIN 12
#define FT_SCK_PORT PORTB
#define FT_SCK_DDR DDRB
#define FT_SCK_BIT PB4
#define FT_RATE_ARDUINO_PIN 13
#define FT_RATE_PORT PORTB
#define FT_RATE_DDR DDRB
#define FT_RATE_BIT PB5

// DOUT groups: channel ch is on
//   ch 0..5:   PIND bit ch + 2
//   ch 6..11:  PINC bit ch - 6
//   ch 12..15: PINB bit ch - 12
#define FT_DOUT_D_SHIFT 2   // channel 0 = PD2
#define FT_DOUT_D_COUNT 6
#define FT_DOUT_C_FIRST 6   // channel 6 = PC0
#define FT_DOUT_C_COUNT 6
#define FT_DOUT_B_FIRST 12  // channel 12 = PB0
#define FT_DOUT_B_COUNT 4

// How many channels of the build sit on each port.
#define FT_CH_ON_D (FT_CHANNELS < FT_DOUT_D_COUNT ? FT_CHANNELS : FT_DOUT_D_COUNT)
#define FT_CH_ON_C \
  (FT_CHANNELS <= FT_DOUT_C_FIRST ? 0                                          \
   : FT_CHANNELS - FT_DOUT_C_FIRST < FT_DOUT_C_COUNT ? FT_CHANNELS - FT_DOUT_C_FIRST \
                                                    : FT_DOUT_C_COUNT)
#define FT_CH_ON_B (FT_CHANNELS <= FT_DOUT_B_FIRST ? 0 : FT_CHANNELS - FT_DOUT_B_FIRST)

// DOUT bit masks per port for this build.
#define FT_DOUT_D_MASK ((uint8_t)(((1u << FT_CH_ON_D) - 1u) << FT_DOUT_D_SHIFT))
#define FT_DOUT_C_MASK ((uint8_t)((1u << FT_CH_ON_C) - 1u))
#define FT_DOUT_B_MASK ((uint8_t)((1u << FT_CH_ON_B) - 1u))

// Arduino pin numbers of DOUT per channel (the digitalRead baseline and documentation).
// A0..A5 are Arduino pins 14..19 on the Uno.
#define FT_DOUT_ARDUINO_PINS {2, 3, 4, 5, 6, 7, 14, 15, 16, 17, 18, 19, 8, 9, 10, 11}

#endif  // FINGERTIP_PINS_H
