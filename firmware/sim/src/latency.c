/* latency.c - see latency.h. */
#include "latency.h"

#include <string.h>

#include <avr_uart.h>
#include <sim_irq.h>

#include "reply.h"
#include "sim.h"

void latency_reset(latency_t *l)
{
    uint64_t cpb = l->cycles_per_byte;
    memset(l, 0, sizeof(*l));
    l->cycles_per_byte = cpb;
}

void latency_ready(latency_t *l, uint64_t now)
{
    if (l->pending)
        l->overwritten++;
    l->pending = true;
    l->ready_at = now;
    l->read_at = 0;
}

void latency_sck_rise(latency_t *l, uint64_t now)
{
    if (l->pending && !l->read_at)
        l->read_at = now;
}

static void byte_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    sim_t *s = param;
    latency_t *l = &s->latency;
    if (s->pty.uart)
        l->cycles_per_byte = ((avr_uart_t *)s->pty.uart)->cycles_per_byte;
    if ((value & 0xFF) != 0 || !l->pending || !l->read_at)
        return;
    uint64_t now = sim_now(s);
    if (l->n < LATENCY_MAX) {
        l->to_read[l->n] = (uint32_t)(l->read_at - l->ready_at);
        l->to_sent[l->n] = (uint32_t)(now + l->cycles_per_byte - l->ready_at);
        l->n++;
    }
    l->pending = false;
}

int latency_attach(sim_t *s)
{
    avr_irq_t *out = avr_io_getirq(s->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
    if (!out)
        return -1;
    avr_irq_register_notify(out, byte_notify, s);
    return 0;
}

static void arr(sim_t *s, reply_t *r, const char *key, const uint32_t *v, uint32_t n)
{
    /* Whole nanoseconds: exact at 16 MHz (62.5 ns a cycle) to within half a nanosecond. */
    jarr_key(r, key);
    for (uint32_t i = 0; i < n; i++)
        jarr_int(r, (int64_t)(sim_cycles_to_us(s, v[i]) * 1000.0 + 0.5));
    jend(r);
}

void latency_write(sim_t *s, reply_t *r, const char *key)
{
    const latency_t *l = &s->latency;
    jobj_key(r, key);
    juint(r, "frames", l->n);
    juint(r, "overwritten", l->overwritten);
    jfix(r, "byte_us", sim_cycles_to_us(s, l->cycles_per_byte), 4);
    arr(s, r, "ready_to_read_ns", l->to_read, l->n);
    arr(s, r, "ready_to_sent_ns", l->to_sent, l->n);
    jend(r);
}
