/*
 * stats.c - SCK timing, read durations and counters (see stats.h).
 */
#include "stats.h"

#include <string.h>

#include "sim.h"

static void mm_add(minmax_t *m, uint64_t v)
{
    if (!m->n || v < m->min)
        m->min = v;
    if (!m->n || v > m->max)
        m->max = v;
    m->n++;
    m->sum += v;
}

void stats_reset(stats_t *st, uint64_t now)
{
    uint64_t f = st->f_cpu;
    bool in_read = st->in_read;
    int pulses = st->read_pulses;
    uint64_t start = st->read_start, last = st->last_fall;
    memset(st, 0, sizeof(*st));
    st->f_cpu = f;
    st->t0 = now;
    /*
     * Keep tracking a read still shifting, so its end is not seen as stray
     * pulses; a read already past pulse 25 belongs to the previous window.
     */
    if (pulses >= 25)
        in_read = false;
    st->in_read = in_read;
    st->read_pulses = pulses;
    st->read_start = start;
    st->last_fall = last;
}

/* Datasheet minimum high/low time is 0.2 us. */
static bool too_short(const stats_t *st, uint64_t cycles)
{
    return cycles * 5000000ULL < st->f_cpu;
}

static void read_finish(stats_t *st, int pulses)
{
    if (pulses >= 25 && pulses <= 27) {
        mm_add(&st->read, st->last_fall - st->read_start);
        st->reads_by_pulses[pulses - 25]++;
    } else {
        st->bad_reads++;
    }
    st->in_read = false;
    st->read_pulses = 0;
}

static uint64_t read_gap(const stats_t *st)
{
    return st->f_cpu / 1000000u * STATS_READ_GAP_US;
}

static uint64_t gain_gap(const stats_t *st)
{
    return st->f_cpu / 1000000u * STATS_GAIN_GAP_US;
}

void stats_sck_rise(stats_t *st, uint64_t now, bool any_dout_low, bool fresh_ready)
{
    st->cur_stray = false;
    st->cur_in_read_violation = false;
    /* A chip that became ready ends a 25/26-pulse read: this rise starts the next. */
    if (st->in_read && st->read_pulses >= 25 && fresh_ready)
        read_finish(st, st->read_pulses);
    /*
     * A complete read takes further pulses as gain pulses only at its own pace: the
     * firmware clocks them in the same loop as the data bits. A rise after a longer low
     * is the firmware's next action, e.g. a power-down commanded right after the read
     * (the product firmware's comes 0.27-0.95 ms after it, within the read gap below).
     */
    if (st->in_read && st->read_pulses >= 25 && now - st->last_fall > gain_gap(st))
        read_finish(st, st->read_pulses);
    /* A long SCK-low gap ends any read (an unfinished one counts as bad). */
    if (st->in_read && now - st->last_fall > read_gap(st))
        read_finish(st, st->read_pulses);
    if (!st->in_read) {
        if (!any_dout_low) {
            st->stray_pulses++;
            st->cur_stray = true;
            return;
        }
        st->in_read = true;
        st->read_start = now;
        st->read_pulses = 0;
    } else {
        uint64_t low = now - st->last_fall;
        mm_add(&st->sck_low_in_read, low);
        if (too_short(st, low))
            st->sck_low_short++;
    }
    st->read_pulses++;
}

void stats_sck_fall(stats_t *st, uint64_t now, uint64_t width, bool was_violation)
{
    mm_add(&st->sck_high, width);
    if (too_short(st, width))
        st->sck_high_short++;
    if (was_violation) {
        if (width > st->longest_violation)
            st->longest_violation = width;
        if (st->cur_in_read_violation && width > st->longest_in_read)
            st->longest_in_read = width;
        return;
    }
    if (!st->in_read)
        return;
    st->last_fall = now;
    if (st->read_pulses >= 27)
        read_finish(st, st->read_pulses);
}

void stats_power_down(stats_t *st)
{
    st->violations++;
    if (st->cur_stray) {
        if (st->stray_pulses)   /* (a stats_reset may have come in between) */
            st->stray_pulses--; /* a deliberate power-down, not a stray clock */
        st->cur_stray = false;
        return;
    }
    if (!st->in_read)
        return;
    if (st->read_pulses <= 1) {
        /* First pulse of a would-be read: a power-down while a chip was ready. */
        st->in_read = false;
        st->read_pulses = 0;
        return;
    }
    st->violations_in_read++;
    st->cur_in_read_violation = true;
    /* The long pulse is not part of the read: judge the read without it. */
    int pulses = st->read_pulses - 1;
    read_finish(st, pulses >= 25 ? pulses : 0);
}

/* --- report --- */

static void mm_write(sim_t *s, reply_t *r, const char *key, const minmax_t *m)
{
    jobj_key(r, key);
    juint(r, "n", m->n);
    if (m->n) {
        jfix(r, "min", sim_cycles_to_us(s, m->min), 4);
        jfix(r, "max", sim_cycles_to_us(s, m->max), 4);
        jfix(r, "mean", sim_cycles_to_us(s, m->sum) / (double)m->n, 4);
    } else {
        jnull(r, "min");
        jnull(r, "max");
        jnull(r, "mean");
    }
    jend(r);
}

static void chips_write(sim_t *s, reply_t *r)
{
    jarr_key(r, "chips");
    for (int i = 0; i < s->bus.nch; i++) {
        const hx711_t *c = &s->bus.chip[i];
        jobj_elem(r);
        jint(r, "ch", i);
        juint(r, "conversions", c->n.conversions);
        juint(r, "reads", c->n.reads);
        juint(r, "missed", c->n.missed);
        juint(r, "partial", c->n.partial);
        juint(r, "power_downs", c->n.power_downs);
        jend(r);
    }
    jend(r);
    jarr_key(r, "reads_per_chip");
    for (int i = 0; i < s->bus.nch; i++)
        jarr_int(r, (int64_t)s->bus.chip[i].n.reads);
    jend(r);
    jarr_key(r, "missed_per_chip");
    for (int i = 0; i < s->bus.nch; i++)
        jarr_int(r, (int64_t)s->bus.chip[i].n.missed);
    jend(r);
}

void stats_write(sim_t *s, reply_t *r, const char *key)
{
    const stats_t *st = &s->stats;
    uint64_t now = sim_now(s);
    uint64_t window = now - st->t0;

    /* Include a finished-looking 25/26-pulse read that is still formally open. */
    minmax_t rd = st->read;
    uint64_t by[3] = {st->reads_by_pulses[0], st->reads_by_pulses[1], st->reads_by_pulses[2]};
    bool provisional = st->in_read && st->read_pulses >= 25 && st->read_pulses <= 27 && !s->bus.sck;
    if (provisional) {
        mm_add(&rd, st->last_fall - st->read_start);
        by[st->read_pulses - 25]++;
    }

    jobj_key(r, key);
    juint(r, "cycle", now);
    jfix(r, "t_us", sim_cycles_to_us(s, now), 4);
    jfix(r, "window_us", sim_cycles_to_us(s, window), 4);
    mm_write(s, r, "sck_high_us", &st->sck_high);
    mm_write(s, r, "sck_low_in_read_us", &st->sck_low_in_read);
    juint(r, "sck_high_short", st->sck_high_short);
    juint(r, "sck_low_short", st->sck_low_short);
    juint(r, "stray_pulses", st->stray_pulses);
    juint(r, "early_dout_samples", st->early_samples);

    mm_write(s, r, "read_us", &rd);
    jnum(r, "read_cpu_share", window ? (double)rd.sum / (double)window : 0.0);
    jobj_key(r, "reads_by_pulses");
    juint(r, "25", by[0]);
    juint(r, "26", by[1]);
    juint(r, "27", by[2]);
    jend(r);
    juint(r, "bad_reads", st->bad_reads);

    jobj_key(r, "violations_60us");
    juint(r, "n", st->violations);
    jfix(r, "longest_us", sim_cycles_to_us(s, st->longest_violation), 4);
    juint(r, "in_read", st->violations_in_read);
    jfix(r, "longest_in_read_us", sim_cycles_to_us(s, st->longest_in_read), 4);
    jend(r);

    chips_write(s, r);

    jobj_key(r, "uart");
    juint(r, "host_to_fw", s->pty.to_fw);
    juint(r, "fw_to_host", s->pty.from_fw);
    juint(r, "tx_dropped", s->pty.tx_dropped);
    juint(r, "rx_pending", s->pty.rx_len);
    juint(r, "xoffs", s->pty.xoffs);
    juint(r, "xoff_guard", s->pty.xoff_guard);
    jend(r);

    jobj_key(r, "events");
    juint(r, "applied", st->events_applied);
    juint(r, "late", st->events_late);
    juint(r, "pending", s->events.n);
    jend(r);

    latency_write(s, r, "latency");

    jobj_key(r, "speed");
    jfix(r, "sim_s", sim_cycles_to_us(s, s->cyc_running) * 1e-6, 6);
    jfix(r, "real_s", s->real_running, 6);
    jfix(r, "wall_s", s->wall_running, 6);
    /* ratio: raw simulator speed; wall_ratio: what throttling left of it. */
    double sim_s = sim_cycles_to_us(s, s->cyc_running) * 1e-6;
    jnum(r, "ratio", s->real_running > 0 ? sim_s / s->real_running : 0.0);
    jnum(r, "wall_ratio", s->wall_running > 0 ? sim_s / s->wall_running : 0.0);
    jend(r);
    jend(r);
}
