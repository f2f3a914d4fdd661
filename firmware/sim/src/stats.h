/*
 * stats.h - exact timing figures taken from the cycle counter.
 *
 * A "read" is tracked on the shared SCK line: it starts at the first rising
 * edge while some DOUT is low and ends at the falling edge of its last
 * pulse. Whether it had 25, 26 or 27 pulses is only known at pulse 27, when
 * a new read starts (a chip became ready again) or when SCK stayed low for
 * more than STATS_GAIN_GAP_US after pulse 25 or later (STATS_READ_GAP_US
 * before it), so a read of 25/26 pulses stays open until then; reports include
 * it provisionally.
 *
 * SCK high > 60 us powers the chips down. Firmware does that on purpose too
 * (power saving, or SCK high from boot until it wants data), so such pulses
 * are split: "in read" = pulse 2 or later of a read (always a firmware bug),
 * the others are deliberate power-downs or a stretched first pulse.
 */
#ifndef FINGERTIP_SIM_STATS_H
#define FINGERTIP_SIM_STATS_H

#include <stdbool.h>
#include <stdint.h>

/* SCK low longer than this ends a read: no read has such a gap between its pulses. */
#define STATS_READ_GAP_US 1000
/*
 * ... and this ends a read that already had its 25 pulses: gain pulses 26/27 follow
 * pulse 25 at the pace of the data bits (SCK low for a few us, an ISR or two at most).
 * A later rise is not part of the read, so SCK held high for a power-down there is a
 * deliberate power-down, not a read broken by a stretched pulse.
 */
#define STATS_GAIN_GAP_US 100

typedef struct minmax {
    uint64_t n, min, max, sum;      /* cycles */
} minmax_t;

typedef struct stats {
    uint64_t f_cpu;
    uint64_t t0;                    /* hcycles at the start of the window */

    minmax_t sck_high;              /* every SCK high pulse */
    minmax_t sck_low_in_read;       /* SCK low between two pulses of one read */
    uint64_t sck_high_short;        /* < 0.2 us: datasheet minimum T3 */
    uint64_t sck_low_short;         /* < 0.2 us: datasheet minimum T4 */
    uint64_t stray_pulses;          /* SCK pulses with no read going on and every DOUT high */
    uint64_t early_samples;         /* DOUT ports read before DOUT was valid (t2) */

    minmax_t read;                  /* complete reads: first rise to last fall */
    uint64_t reads_by_pulses[3];    /* 25, 26, 27 */
    uint64_t bad_reads;             /* fewer than 25 or more than 27 pulses */

    uint64_t violations;            /* SCK high > 60 us (chips powered down) */
    uint64_t longest_violation;     /* cycles */
    uint64_t violations_in_read;    /* ... of which inside a read: a firmware bug */
    uint64_t longest_in_read;       /* cycles */

    uint64_t events_applied;
    uint64_t events_late;           /* scheduled for a time already past */

    /* Read tracker. */
    bool cur_stray;                 /* the pulse now high was counted as stray */
    bool cur_in_read_violation;     /* the pulse now high broke a read */
    bool in_read;
    int read_pulses;
    uint64_t read_start, last_fall;
} stats_t;

void stats_reset(stats_t *st, uint64_t now);
void stats_sck_rise(stats_t *st, uint64_t now, bool any_dout_low, bool fresh_ready);
void stats_sck_fall(stats_t *st, uint64_t now, uint64_t width, bool was_violation);
void stats_power_down(stats_t *st);

struct sim;
struct reply;
/* Writes the "stats" object (as key 'key') into the reply being built. */
void stats_write(struct sim *s, struct reply *r, const char *key);

#endif
