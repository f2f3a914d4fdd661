/*
 * pty_bridge.h - UART0 <-> a private pseudo-terminal.
 *
 * Not simavr's uart_pty part: that one makes a global /tmp/simavr-uart0
 * link (parallel runs collide) and a thread that hung on stop. Here the pty
 * comes from openpty(), is raw, and is serviced without blocking from the
 * run loop, so every harness process is independent.
 *
 * We keep the slave side open ourselves: the master then never reports
 * EIO/HUP while no client is connected (or between two clients), and the
 * raw termios settings persist across client open/close.
 */
#ifndef FINGERTIP_SIM_PTY_BRIDGE_H
#define FINGERTIP_SIM_PTY_BRIDGE_H

#include <poll.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <sim_avr.h>

#define PTY_RING 65536

typedef struct ring {
    uint8_t buf[PTY_RING];
    size_t head, len;
} ring_t;

typedef struct pty_bridge {
    int master, slave;
    char path[128];
    char link[512];             /* optional user symlink, removed on close */

    avr_t *avr;
    void *uart;                 /* avr_uart_t of UART0, to check its RX fifo */
    avr_irq_t *irq_input;
    bool xoff;                  /* firmware RX fifo full: stop feeding */

    ring_t rx;                  /* host -> firmware, waiting for XON / RXEN */
    ring_t tx;                  /* firmware -> host, waiting for the pty */
    size_t rx_len;              /* mirror of rx.len for reports */

    uint64_t to_fw, from_fw, tx_dropped;
    uint64_t xoffs;             /* times the UART said XOFF (its fifo was full) */
    uint64_t xoff_guard;        /* XOFF lifted by our fifo check, not by an XON */
} pty_bridge_t;

int pty_open(pty_bridge_t *p, const char *link);
int pty_attach(pty_bridge_t *p, avr_t *avr);
/* Fill pollfd for the run loop; returns how many were used (0..1). */
int pty_pollfd(pty_bridge_t *p, struct pollfd *pfd);
/* Move bytes: read host, write firmware output, feed the firmware RX if allowed. */
void pty_service(pty_bridge_t *p, bool cpu_alive);
void pty_after_reset(pty_bridge_t *p);
void pty_close(pty_bridge_t *p);

#endif
