/*
 * latency.h - from an HX711 conversion to its frame's last bit on the UART, per frame.
 *
 * Chip 0 signals a conversion ready (DOUT low): the clock starts. The firmware's first SCK
 * rise after it starts the read (ready -> read). The next frame delimiter (a 0x00 byte, the
 * end of every COBS frame) written to UART0 after that read ends the frame; its last bit
 * leaves the pin one byte time (simavr's cycles_per_byte, from UBRR and U2X) after the
 * write (ready -> sent). Each frame's figures are kept (up to LATENCY_MAX) so the client can
 * take percentiles; `stats` reports them and `stats_reset` clears them.
 */
#ifndef FINGERTIP_SIM_LATENCY_H
#define FINGERTIP_SIM_LATENCY_H

#include <stdbool.h>
#include <stdint.h>

#define LATENCY_MAX 8192

typedef struct latency {
    bool pending;               /* a conversion of chip 0 waits for its frame */
    uint64_t ready_at, read_at; /* hcycles; read_at 0 = not read yet */
    uint64_t cycles_per_byte;   /* of UART0 at the last byte */
    uint32_t n;                 /* frames measured */
    uint32_t overwritten;       /* conversions that came before the previous one was sent */
    uint32_t to_read[LATENCY_MAX];   /* cycles, ready -> read start */
    uint32_t to_sent[LATENCY_MAX];   /* cycles, ready -> last bit of the frame on the pin */
} latency_t;

struct sim;
struct reply;

void latency_reset(latency_t *l);
void latency_ready(latency_t *l, uint64_t now);
void latency_sck_rise(latency_t *l, uint64_t now);
/* Registers the UART0 output watcher; call once the core and the pty are attached. */
int latency_attach(struct sim *s);
void latency_write(struct sim *s, struct reply *r, const char *key);

#endif
