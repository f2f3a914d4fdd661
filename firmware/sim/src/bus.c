/*
 * bus.c - the simulated HX711s wired to the Uno's pins through simavr.
 *
 * Wiring (fixed by the readout board): one shared SCK on PB4 (D12), RATE on
 * PB5 (D13), DOUT of channel 0..5 on PD2..PD7, 6..11 on PC0..PC5, 12..15 on
 * PB0..PB3. This file turns simavr pin notifications and cycle timers into
 * calls on the chip model, and the chip model's DOUT levels into pin levels.
 */
#include <stdio.h>
#include <string.h>

#include <avr_ioport.h>
#include <sim_time.h>

#include "sim.h"

static const char *const pin_names[HX711_MAX_CHANNELS] = {
    "D2", "D3", "D4", "D5", "D6", "D7", "A0", "A1", "A2", "A3", "A4", "A5", "D8", "D9", "D10", "D11",
};

const char *bus_pin_name(int ch)
{
    return pin_names[ch];
}

static char ch_port(int ch)
{
    return ch < 6 ? 'D' : ch < 12 ? 'C' : 'B';
}

static int ch_bit(int ch)
{
    return ch < 6 ? ch + 2 : ch < 12 ? ch - 6 : ch - 12;
}

static bus_port_t *port_of(bus_t *b, char name)
{
    return &b->port[name == 'B' ? 0 : name == 'C' ? 1 : 2];
}

static uint64_t to_avr(const sim_t *s, uint64_t hcycles)
{
    return hcycles - s->cyc_offset;
}

/* --- DOUT --- */

/*
 * Drive a DOUT line. Two things make it stick: the port's "external" levels
 * (otherwise a firmware write to PORTx re-asserts the pull-up level on our
 * input pins, NOTES.md) and the pin IRQ itself, which sets the PIN bit.
 */
static void set_dout(sim_t *s, int ch, int level)
{
    bus_t *b = &s->bus;
    bus_port_t *p = port_of(b, ch_port(ch));
    uint8_t bit = (uint8_t)(1u << ch_bit(ch));
    b->dout_level[ch] = level;
    b->pending_mask &= ~(1u << ch);
    p->value = level ? (uint8_t)(p->value | bit) : (uint8_t)(p->value & ~bit);
    avr_ioport_external_t ext = {.name = (unsigned long)p->name, .mask = p->mask, .value = p->value};
    avr_ioctl(s->avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(p->name), &ext);
    avr_raise_irq(b->dout_irq[ch], (uint32_t)level);
}

static avr_cycle_count_t dout_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    (void)when;
    sim_t *s = param;
    uint32_t m = s->bus.pending_mask;
    for (int ch = 0; m; ch++, m >>= 1)
        if (m & 1)
            set_dout(s, ch, s->bus.pending_level[ch]);
    return 0;
}

static void chip_drive(void *ctx, int ch, int level, bool delayed)
{
    sim_t *s = ctx;
    bus_t *b = &s->bus;
    if (s->cpu_gone)
        return;
    if (!delayed || !b->dout_delay) {
        set_dout(s, ch, level);
        return;
    }
    /* t2: DOUT settles up to 0.1 us after the SCK edge; sampling earlier reads the old bit. */
    b->pending_level[ch] = level;
    b->pending_mask |= 1u << ch;
    avr_cycle_timer_register(s->avr, b->dout_delay, dout_timer, s);
}

/* --- conversions --- */

static void apply_value(sim_t *s, const event_t *e);

/* Apply every scheduled value due at or before 'now' (hcycles). */
static void apply_due(sim_t *s, uint64_t now)
{
    event_t e;
    while (events_peek(&s->events) && events_peek(&s->events)->at <= now) {
        events_pop(&s->events, &e);
        apply_value(s, &e);
    }
}

static avr_cycle_count_t conv_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    hx711_t *c = param;
    sim_t *s = c->ops->ctx;
    uint64_t now = when + s->cyc_offset;
    /* simavr orders same-cycle timers arbitrarily: a value due now is always converted. */
    apply_due(s, now);
    uint64_t next = hx711_convert(c, now);
    if (c->ch == 0 && c->ready)
        latency_ready(&s->latency, now);
    return next ? to_avr(s, next) : 0;
}

static void chip_reschedule(void *ctx, int ch, uint64_t at)
{
    sim_t *s = ctx;
    if (s->cpu_gone)
        return;
    hx711_t *c = &s->bus.chip[ch];
    avr_cycle_timer_cancel(s->avr, conv_timer, c);
    if (!at)
        return;
    uint64_t now = sim_now(s);
    avr_cycle_timer_register(s->avr, at > now ? at - now : 0, conv_timer, c);
}

/* --- SCK and RATE --- */

static avr_cycle_count_t pd_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    (void)when;
    sim_t *s = param;
    s->bus.sck_powered_down = true;
    stats_power_down(&s->stats);
    for (int i = 0; i < s->bus.nch; i++)
        hx711_power_down(&s->bus.chip[i]);
    return 0;
}

static void sck_rise(sim_t *s, uint64_t now)
{
    bus_t *b = &s->bus;
    bool any_low = false, fresh = false;
    for (int i = 0; i < b->nch; i++) {
        const hx711_t *c = &b->chip[i];
        any_low |= b->dout_level[i] == 0;
        fresh |= c->mode == HX711_OK && c->powered && c->ready && c->pulses == 0;
    }
    b->sck = 1;
    b->sck_rise_at = now;
    /* Power-down is "high for longer than 60 us": fire one cycle past it. */
    avr_cycle_timer_register(s->avr, avr_usec_to_cycles(s->avr, 60) + 1, pd_timer, s);
    stats_sck_rise(&s->stats, now, any_low, fresh);
    latency_sck_rise(&s->latency, now);
    for (int i = 0; i < b->nch; i++)
        hx711_sck_rise(&b->chip[i], now);
}

static void sck_fall(sim_t *s, uint64_t now)
{
    bus_t *b = &s->bus;
    bool violation = b->sck_powered_down;
    b->sck = 0;
    b->sck_fall_at = now;
    b->sck_powered_down = false;
    avr_cycle_timer_cancel(s->avr, pd_timer, s);
    stats_sck_fall(&s->stats, now, now - b->sck_rise_at, violation);
    for (int i = 0; i < b->nch; i++) {
        hx711_t *c = &b->chip[i];
        if (c->mode == HX711_OK && !c->powered)
            hx711_power_up(c, now);     /* SCK low again: wake up with gain 128 */
        else
            hx711_sck_fall(c, now);
    }
}

static void sck_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    sim_t *s = param;
    int level = value & 1;
    if (level == s->bus.sck)
        return;     /* simavr notifies the first raise even when nothing changed */
    if (level)
        sck_rise(s, sim_now(s));
    else
        sck_fall(s, sim_now(s));
}

static void rate_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    sim_t *s = param;
    int level = value & 1;
    if (level == s->bus.rate80)
        return;
    s->bus.rate80 = level;
    uint64_t now = sim_now(s);
    for (int i = 0; i < s->bus.nch; i++)
        hx711_set_rate(&s->bus.chip[i], now, level);
}

/* Firmware read a DOUT port: too early if a DOUT change is still in flight. */
static void pin_read_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    bus_port_t *p = param;
    if (p->s->bus.pending_mask & p->channels)
        p->s->stats.early_samples++;
}

/* --- scheduled input values --- */

static void apply_value(sim_t *s, const event_t *e)
{
    hx711_t *c = &s->bus.chip[s->bus.route[e->ch]];
    if (e->input_b)
        c->in_b = e->value;
    else
        c->in_a = e->value;
    s->stats.events_applied++;
}

static avr_cycle_count_t events_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    sim_t *s = param;
    apply_due(s, when + s->cyc_offset);
    const event_t *next = events_peek(&s->events);
    return next ? to_avr(s, next->at) : 0;
}

void bus_events_rearm(sim_t *s)
{
    if (s->cpu_gone)
        return;
    avr_cycle_timer_cancel(s->avr, events_timer, s);
    const event_t *next = events_peek(&s->events);
    if (!next)
        return;
    uint64_t now = sim_now(s);
    avr_cycle_timer_register(s->avr, next->at > now ? next->at - now : 0, events_timer, s);
}

/* --- setup --- */

static int watch(sim_t *s, char port, int bit, avr_irq_notify_t fn, void *param)
{
    avr_irq_t *irq = avr_io_getirq(s->avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
    if (!irq)
        return -1;
    avr_irq_register_notify(irq, fn, param);
    return 0;
}

int bus_attach(sim_t *s, int nch, uint32_t dout_delay)
{
    bus_t *b = &s->bus;
    memset(b, 0, sizeof(*b));
    b->nch = nch;
    b->dout_delay = dout_delay;
    b->ops = (hx711_ops_t){.drive = chip_drive, .reschedule = chip_reschedule, .ctx = s};
    const char names[3] = {'B', 'C', 'D'};
    for (int i = 0; i < 3; i++)
        b->port[i] = (bus_port_t){.s = s, .name = names[i]};

    if (watch(s, SIM_SCK_PORT, SIM_SCK_BIT, sck_notify, s) ||
        watch(s, SIM_RATE_PORT, SIM_RATE_BIT, rate_notify, s)) {
        fprintf(stderr, "fingertip-sim: this core has no port B\n");
        return -1;
    }
    for (int ch = 0; ch < nch; ch++) {
        bus_port_t *p = port_of(b, ch_port(ch));
        p->mask |= (uint8_t)(1u << ch_bit(ch));
        p->value |= (uint8_t)(1u << ch_bit(ch));
        p->channels |= 1u << ch;
        b->dout_irq[ch] = avr_io_getirq(s->avr, AVR_IOCTL_IOPORT_GETIRQ(ch_port(ch)), ch_bit(ch));
        hx711_init(&b->chip[ch], ch, s->f_cpu, &b->ops);
        hx711_seed(&b->chip[ch], s->seed);
        b->route[ch] = (int8_t)ch;
    }
    for (int i = 0; i < 3; i++) {
        bus_port_t *p = &b->port[i];
        if (!p->mask)
            continue;
        /* PIN reads are reported on a FILTERED irq: unfilter it to see every read. */
        avr_irq_t *pin = avr_io_getirq(s->avr, AVR_IOCTL_IOPORT_GETIRQ(p->name), IOPORT_IRQ_REG_PIN);
        pin->flags &= ~IRQ_FLAG_FILTERED;
        avr_irq_register_notify(pin, pin_read_notify, p);
    }
    uint64_t now = sim_now(s);
    for (int ch = 0; ch < nch; ch++) {
        set_dout(s, ch, 1);
        hx711_power_up(&b->chip[ch], now);
    }
    return 0;
}

/* avr_reset() cleared every cycle timer and every PIN register: rebuild both. */
void bus_after_reset(sim_t *s)
{
    bus_t *b = &s->bus;
    uint64_t now = sim_now(s);
    for (int ch = 0; ch < b->nch; ch++) {
        int level = (b->pending_mask >> ch) & 1 ? b->pending_level[ch] : b->dout_level[ch];
        /* Same-value raises are filtered: bounce the line so the PIN bit is rewritten. */
        avr_raise_irq(b->dout_irq[ch], (uint32_t)!level);
        set_dout(s, ch, level);
    }
    /* The reset releases SCK (input, board pull-down): a high SCK falls now. */
    if (b->sck)
        sck_fall(s, now);
    for (int ch = 0; ch < b->nch; ch++)
        chip_reschedule(s, ch, b->chip[ch].next_conv);
    bus_events_rearm(s);
}

void bus_set_mode(sim_t *s, int ch, hx711_mode_t mode)
{
    hx711_set_mode(&s->bus.chip[ch], sim_now(s), mode, s->bus.sck != 0);
}

void bus_reseed(sim_t *s, uint64_t seed)
{
    s->seed = seed;
    for (int ch = 0; ch < s->bus.nch; ch++)
        hx711_seed(&s->bus.chip[ch], seed);
}

void bus_apply_now(sim_t *s, int ch, bool input_b, int64_t value)
{
    event_t e = {.ch = (int8_t)ch, .input_b = input_b, .value = value};
    apply_value(s, &e);
}

int bus_pin_level(sim_t *s, int ch)
{
    if (s->cpu_gone)
        return s->bus.dout_level[ch];
    avr_ioport_state_t st;
    if (avr_ioctl(s->avr, AVR_IOCTL_IOPORT_GETSTATE(ch_port(ch)), &st))
        return -1;
    return (st.pin >> ch_bit(ch)) & 1;
}
