// Fingertip firmware for the Arduino Uno: HX711 strain-gauge channels streamed over the wire
// protocol v1 (docs/protocol.md). The device logic is lib/fingertip_core (tested natively);
// this file only wires it to the board. Pin map: pins.h.
//
// Build options (-D...): FT_CHANNELS=4 (default) or 16; FT_BUILD_ID=0x<8 hex digits of the
// git commit>; FT_READ_SEQUENTIAL_DIGITALREAD for the digitalRead benchmark baseline.
// SERIAL_TX_BUFFER_SIZE=128 is required (for the Arduino core too).
#include <Arduino.h>
#include <avr/wdt.h>

#include "fingertip_core.h"
#include "pins.h"
#include "uno_hal.h"

// MCUSR at reset (bit 0 power-on, 1 external, 2 brown-out, 3 watchdog), kept in .noinit so
// that the C runtime does not clear it after .init3 wrote it.
uint8_t g_reset_cause __attribute__((section(".noinit")));

// Runs in .init3, before the C runtime initialises .data/.bss and before constructors, as
// avr-libc documents for watchdog resets: after a watchdog reset the WDT stays enabled with
// its shortest timeout (WDRF forces WDE), so it must be disabled before anything slow runs.
// MCUSR must be cleared to clear WDRF. Optiboot clears MCUSR itself and hands the value
// over in r2; take r2 when MCUSR reads 0 (a reset always sets at least one MCUSR bit).
extern "C" void ftInitResetCause(void) __attribute__((naked, used, section(".init3")));
extern "C" void ftInitResetCause(void) {
  uint8_t from_bootloader;
  __asm__ __volatile__("mov %0, r2" : "=r"(from_bootloader));
  const uint8_t mcusr = MCUSR;
  MCUSR = 0;
  wdt_disable();
  g_reset_cause = static_cast<uint8_t>((mcusr != 0 ? mcusr : from_bootloader) & 0x0F);
}

namespace {

UnoHal hal;
ftc::ChannelState channel_state[FT_CHANNELS];
// Constructed in .init6, after .init3 set g_reset_cause.
ftc::Device device(hal, channel_state,
                   ftc::DeviceConfig{FT_CHANNELS, static_cast<uint32_t>(FT_BUILD_ID),
                                     g_reset_cause});

}  // namespace

void setup() {
  hal.begin();             // SCK high: every HX711 powers down...
  delayMicroseconds(100);  // ...after 60 us
  device.boot();           // SCK low: they restart at gain 128; boot messages out
  // Nothing in the loop waits; a loop stuck for 250 ms is a bug: reset.
  wdt_enable(WDTO_250MS);
}

void loop() {
  device.poll();
  wdt_reset();
}
