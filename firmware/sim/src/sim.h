/*
 * sim.h - the harness state shared by its parts.
 *
 * One process = one simulated board. Everything runs on a single thread
 * (the simavr run loop), so there is no locking anywhere: simavr callbacks
 * (pin changes, cycle timers, UART) and the control/pty servicing between
 * instruction slices all touch this struct in turn.
 *
 * Time: "harness cycles" (hcycles) are avr->cycle plus an offset that keeps
 * them monotonic across avr_reset(), so scheduled values, stats windows and
 * `until` targets keep their meaning after a simulated reset.
 */
#ifndef FINGERTIP_SIM_SIM_H
#define FINGERTIP_SIM_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include <sim_avr.h>

#include "events.h"
#include "hx711.h"
#include "pty_bridge.h"
#include "reply.h"
#include "stats.h"
#include "latency.h"

#define SIM_PROTOCOL_VERSION 1

/* Pin map (Arduino Uno, fixed by the readout board). */
#define SIM_SCK_PORT 'B'
#define SIM_SCK_BIT 4       /* D12 */
#define SIM_RATE_PORT 'B'
#define SIM_RATE_BIT 5      /* D13 */

struct sim;

/* A port that carries DOUT lines: its external levels and its PIN-read watch. */
typedef struct bus_port {
    struct sim *s;
    char name;              /* 'B', 'C', 'D' */
    uint8_t mask;           /* DOUT bits we drive on this port */
    uint8_t value;          /* their levels */
    uint32_t channels;      /* channel bitmask living on this port */
} bus_port_t;

typedef struct bus {
    int nch;
    bus_port_t port[3];     /* B, C, D */
    hx711_t chip[HX711_MAX_CHANNELS];
    /* Which chip each channel's bridge feeds: two DOUT wires swapped on the board make
     * channel a's bridge appear on pin b (identity unless `swap`). */
    int8_t route[HX711_MAX_CHANNELS];
    avr_irq_t *dout_irq[HX711_MAX_CHANNELS];
    int dout_level[HX711_MAX_CHANNELS];     /* level on the wire now */

    /* SCK / RATE as last seen (own copy: simavr's first raise always notifies). */
    int sck;
    int rate80;
    uint64_t sck_rise_at, sck_fall_at;      /* hcycles */
    bool sck_powered_down;                  /* the current high pulse passed 60 us */

    /* t2 model: DOUT changes this many cycles after the SCK-rising write. */
    uint32_t dout_delay;
    uint32_t pending_mask;                  /* channels with a delayed DOUT change */
    int pending_level[HX711_MAX_CHANNELS];
    hx711_ops_t ops;
} bus_t;

typedef enum {
    RUN_HELD = 0,
    RUN_FREE,
} run_state_t;

typedef struct sim {
    avr_t *avr;
    const char *elf_path;
    uint64_t f_cpu;
    uint64_t cyc_offset;        /* hcycles = avr->cycle + cyc_offset */
    bool cpu_gone;              /* cpu_Done: simavr freed the core, never touch avr again */
    uint64_t gone_at;           /* hcycles when the core stopped */

    bus_t bus;
    stats_t stats;
    latency_t latency;
    events_t events;
    pty_bridge_t pty;
    reply_t out;

    /* Control state. */
    run_state_t run;
    bool until_active;
    uint64_t until_at;          /* hcycles */
    const char *until_cmd;      /* "until" or "step", for the reply */
    double throttle;            /* 0 = free-running, else sim seconds per real second */
    double thr_real0;           /* throttle anchor (real seconds) ... */
    uint64_t thr_cyc0;          /* ... and the hcycles at that moment */
    double real_running;        /* real seconds spent executing (raw simulator speed) */
    double wall_running;        /* real seconds in the running state, throttle waits included */
    uint64_t cyc_running;       /* hcycles simulated while running */
    uint64_t seed;
    bool stdin_eof;
    bool quit;
    const char *quit_reason;
    bool verbose;
} sim_t;

static inline uint64_t sim_now(const sim_t *s)
{
    return s->cpu_gone ? s->gone_at : s->avr->cycle + s->cyc_offset;
}

static inline double sim_cycles_to_us(const sim_t *s, uint64_t cycles)
{
    return (double)cycles * 1e6 / (double)s->f_cpu;
}

double sim_real_seconds(void);
/* Throttled: the real seconds at which the current simulated instant is due by the pacing. */
double sim_due_seconds(const sim_t *s);

/* bus.c: chips on the pins. */
int bus_attach(sim_t *s, int nch, uint32_t dout_delay);
void bus_after_reset(sim_t *s);
void bus_set_mode(sim_t *s, int ch, hx711_mode_t mode);
void bus_apply_now(sim_t *s, int ch, bool input_b, int64_t value);
void bus_events_rearm(sim_t *s);
void bus_reseed(sim_t *s, uint64_t seed);
int bus_pin_level(sim_t *s, int ch);
const char *bus_pin_name(int ch);

/* control.c: the line protocol. */
void control_feed(sim_t *s, const char *buf, size_t len);
bool control_blocked(const sim_t *s);
bool control_has_line(void);
void control_process(sim_t *s);
void control_until_reached(sim_t *s);
void control_hello(sim_t *s);
void control_exit_report(sim_t *s);
void control_cpu_event(sim_t *s, const char *state);
void control_reset_mcu(sim_t *s);

#endif
