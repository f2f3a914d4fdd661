/*
 * hx711.h - behavioural model of one HX711 24-bit bridge ADC.
 *
 * The model knows nothing about simavr: it is driven by SCK edges, RATE
 * changes and conversion instants (all in "harness cycles", a monotonic
 * cycle count that survives MCU resets), and acts on the world through two
 * callbacks (drive DOUT, (re)schedule the next conversion). This keeps the
 * datasheet logic in one place and testable in isolation.
 *
 * Datasheet behaviour modelled:
 *  - conversions at 10 or 80 SPS following the RATE pin; after power-up,
 *    a RATE change or a gain/channel change, the first conversion comes
 *    4 periods later (the datasheet's 400 ms / 50 ms settling time);
 *  - DOUT low = conversion ready; each SCK rising edge shifts the next bit
 *    out MSB first (24-bit two's complement); pulse 25 pulls DOUT high;
 *    25/26/27 pulses select gain 128 A / 32 B / 64 A for what follows;
 *  - SCK high > 60 us powers the chip down (DOUT high, no conversions);
 *    SCK low again powers it up with gain 128 A;
 *  - values saturate at 0x7FFFFF / 0x800000.
 * Not in the datasheet, our choice: a conversion completing while a read is
 * shifting (last SCK edge < HX711_ABANDON_US ago) is lost (counted missed);
 * a read left unfinished longer than that (MCU reset mid-read, driver
 * timeout) is abandoned and the new conversion is presented, so a chip can
 * never lock up.
 */
#ifndef FINGERTIP_SIM_HX711_H
#define FINGERTIP_SIM_HX711_H

#include <stdbool.h>
#include <stdint.h>

#define HX711_MAX_CHANNELS 16
#define HX711_SETTLE_PERIODS 4
#define HX711_ABANDON_US 1000
#define HX711_MAX_CODE 0x7FFFFF
#define HX711_MIN_CODE (-0x800000)

typedef enum {
    HX711_OK = 0,        /* alive and converting */
    HX711_ABSENT,        /* no chip / dead: DOUT stays high forever */
    HX711_STUCK_LOW,     /* broken chip or shorted line: DOUT stays low */
} hx711_mode_t;

/* Gain code = number of SCK pulses in the read minus 24. */
typedef enum {
    HX711_GAIN_A128 = 1,
    HX711_GAIN_B32 = 2,
    HX711_GAIN_A64 = 3,
} hx711_gain_t;

typedef struct hx711_ops {
    /* Drive this chip's DOUT; 'delayed' models t2 (SCK rise to DOUT valid). */
    void (*drive)(void *ctx, int ch, int level, bool delayed);
    /* The next conversion instant changed (0 = none); the host re-arms its timer. */
    void (*reschedule)(void *ctx, int ch, uint64_t at);
    void *ctx;
} hx711_ops_t;

typedef struct hx711_counters {
    uint64_t conversions;   /* conversions presented on DOUT */
    uint64_t reads;         /* reads that reached pulse 25 */
    uint64_t missed;        /* conversions lost: overwritten unread or landed mid-read */
    uint64_t partial;       /* reads aborted before pulse 25 (power-down, abandoned) */
    uint64_t power_downs;   /* entries into power-down */
    uint64_t settles;       /* settling restarts (power-up, rate, gain) */
} hx711_counters_t;

typedef struct hx711 {
    int ch;
    hx711_mode_t mode;
    bool powered;
    bool rate80;            /* RATE pin level as last seen */
    hx711_gain_t gain;      /* gain/channel of the conversions now running */
    bool ready;             /* a conversion waits to be read (DOUT low) */
    uint32_t shift;         /* 24-bit word being shifted out */
    int pulses;             /* SCK pulses in the current read, 0 = idle */
    uint64_t last_edge;     /* harness cycle of the last SCK rise of this read */
    uint64_t next_conv;     /* harness cycle of next conversion, 0 = none */
    uint64_t f_cpu;         /* cycles per second, to turn periods into cycles */
    double ppm;             /* oscillator error: >0 converts faster */

    int64_t in_a, in_b;     /* analog inputs in counts at gain 128 */
    double sigma;           /* Gaussian noise, counts at gain 128 */
    uint64_t rng;           /* splitmix64 state */
    bool have_spare;        /* Box-Muller gives two normals at a time */
    double spare;

    /* Build faults (ours, for `fingertip check`): the input as a faulty bridge presents
     * it. in = fault_ref + fault_scale * (in - fault_ref) + fault_offset. */
    double fault_scale;     /* 1 ok; -1 bridge wired reversed; 0.15 a loose gauge */
    int64_t fault_ref;      /* the input when the fault was set: the bridge at rest */
    int64_t fault_offset;   /* an open bridge: far beyond full scale */

    int32_t last_value;     /* last converted value (for 'chips') */
    hx711_counters_t n;
    const hx711_ops_t *ops;
} hx711_t;

void hx711_init(hx711_t *c, int ch, uint64_t f_cpu, const hx711_ops_t *ops);
void hx711_seed(hx711_t *c, uint64_t seed);
uint64_t hx711_period(const hx711_t *c);

void hx711_power_up(hx711_t *c, uint64_t now);
void hx711_power_down(hx711_t *c);
void hx711_set_rate(hx711_t *c, uint64_t now, bool rate80);
void hx711_set_mode(hx711_t *c, uint64_t now, hx711_mode_t mode, bool sck_high);

/* Conversion instant (called from the host's timer): returns the next one. */
uint64_t hx711_convert(hx711_t *c, uint64_t now);
void hx711_sck_rise(hx711_t *c, uint64_t now);
void hx711_sck_fall(hx711_t *c, uint64_t now);

/* Pure: what the chip would output for an input, noise and gain. */
int32_t hx711_code(int64_t input, double noise, hx711_gain_t gain);

/* Build faults: "ok", "reversed", "loose", "open" (0 done, -1 unknown name). */
int hx711_set_fault(hx711_t *c, const char *name);
const char *hx711_fault_name(const hx711_t *c);

const char *hx711_mode_name(hx711_mode_t m);
int hx711_mode_parse(const char *s, hx711_mode_t *out);

#endif
