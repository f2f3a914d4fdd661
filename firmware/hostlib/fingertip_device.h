/* The fingertip device (lib/fingertip_core on a simulated board) as a C library for the host:
 * what host/fingertip/sim/device/virtual_firmware.py loads with ctypes. Built by
 * `make -C firmware hostlib` into firmware/build/host/libfingertip_device.so.
 *
 * Time is device time in microseconds, 64 bits (the firmware sees micros(): 4 us steps,
 * wrapping at 2^32). Whatever the device sends is appended to an output buffer that the caller
 * reads with ftd_tx_data / ftd_tx_size and empties with ftd_tx_clear. Functions that run the
 * device return the size of that buffer (>= 0), or a negative FTD_E* code. */
#ifndef FINGERTIP_DEVICE_H
#define FINGERTIP_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define FTD_API __attribute__((visibility("default")))

typedef struct FtdDevice FtdDevice;

/* Each chip's input in counts at gain 128 at device time t_us; return 0, or non-zero on error
 * (the running call then returns FTD_E_INPUTS). Called only when a chip is read. */
typedef int (*ftd_inputs_fn)(void *ctx, uint64_t t_us, double *inputs, uint8_t n);

enum {
  FTD_OK = 0,
  FTD_E_INPUTS = -1,    /* the inputs callback failed */
  FTD_E_NAN = -2,       /* an input was NaN */
  FTD_E_STUCK = -3,     /* the device did not move on from a due event (a bug) */
  FTD_E_ARGUMENT = -4,  /* bad channel count or channel */
};

/* Everything the host reads of the device at once (the observers of ftc::Device). */
typedef struct {
  uint8_t channels, rate_sps, decimation, gain, flags, streaming, powered, tare_active;
  uint16_t live_mask, stale_mask;
  int32_t offsets[16];
  uint32_t stats[10]; /* STATS payload in wire order; stats[0] = micros() now */
} FtdState;

FTD_API FtdDevice *ftd_create(uint8_t channels, uint32_t build_id, uint8_t reset_cause);
FTD_API void ftd_destroy(FtdDevice *d);
/* Power-on state at device time 0, as after a reset of the Uno (no output). */
FTD_API void ftd_reset(FtdDevice *d);
FTD_API void ftd_set_inputs(FtdDevice *d, ftd_inputs_fn fn, void *ctx);
/* Chips in mask never become ready (missing or broken); the others work. */
FTD_API int ftd_set_dead_mask(FtdDevice *d, uint16_t mask);
FTD_API uint16_t ftd_dead_mask(const FtdDevice *d);

/* Reset, then boot with the device clock at start_us (its output goes to the buffer). */
FTD_API int64_t ftd_boot(FtdDevice *d, uint64_t start_us);
/* Host bytes arrive at the current device time; the device takes every complete command. */
FTD_API int64_t ftd_receive(FtdDevice *d, const uint8_t *data, size_t len);
/* Runs device time forward to to_us, stopping at every conversion, chip deadline and STATS. */
FTD_API int64_t ftd_advance(FtdDevice *d, uint64_t to_us);
/* Device time of the next thing the device does on its own, or -1 when nothing is due. */
FTD_API int64_t ftd_next_due(const FtdDevice *d);
FTD_API uint64_t ftd_now(const FtdDevice *d);

FTD_API const uint8_t *ftd_tx_data(const FtdDevice *d);
FTD_API size_t ftd_tx_size(const FtdDevice *d);
FTD_API void ftd_tx_clear(FtdDevice *d);

FTD_API void ftd_state(FtdDevice *d, FtdState *out);

/* Constants of the C++ side, for the host to check against tests/vectors/protocol_v1.json:
 * ftd_constant("max_frame", &v) -> 0 and v, or -1 for an unknown name; ftd_constant_name(i)
 * lists the names (NULL past the end). ftd_stats_field(i): the STATS counter names in wire
 * order (NULL past the end). */
FTD_API int ftd_constant(const char *name, int64_t *value);
FTD_API const char *ftd_constant_name(int i);
FTD_API const char *ftd_stats_field(int i);

#ifdef __cplusplus
}
#endif

#endif /* FINGERTIP_DEVICE_H */
