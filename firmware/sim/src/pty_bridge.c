/*
 * pty_bridge.c - UART0 bridged to an openpty() pseudo-terminal.
 */
#define _GNU_SOURCE
#include "pty_bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <pty.h>
#include <stdio.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include <avr_uart.h>

/* ATmega328P: UCSR0B and its RXEN0 bit (bytes sent before RX is on would be lost). */
#define UCSR0B_ADDR 0xC1
#define RXEN0_BIT 4

/* --- byte rings --- */

static size_t ring_space(const ring_t *r)
{
    return PTY_RING - r->len;
}

static bool ring_put(ring_t *r, uint8_t b)
{
    if (r->len == PTY_RING)
        return false;
    r->buf[(r->head + r->len) % PTY_RING] = b;
    r->len++;
    return true;
}

static uint8_t ring_get(ring_t *r)
{
    uint8_t b = r->buf[r->head];
    r->head = (r->head + 1) % PTY_RING;
    r->len--;
    return b;
}

/* Longest contiguous run of stored bytes starting at head. */
static size_t ring_chunk(const ring_t *r)
{
    size_t n = PTY_RING - r->head;
    return n < r->len ? n : r->len;
}

static void ring_drop(ring_t *r, size_t n)
{
    r->head = (r->head + n) % PTY_RING;
    r->len -= n;
}

/* --- pty --- */

int pty_open(pty_bridge_t *p, const char *link)
{
    memset(p, 0, sizeof(*p));
    p->master = p->slave = -1;
    if (openpty(&p->master, &p->slave, p->path, NULL, NULL) < 0) {
        perror("fingertip-sim: openpty");
        return -1;
    }
    struct termios t;
    if (tcgetattr(p->slave, &t) == 0) {
        cfmakeraw(&t);          /* no echo, no CR/LF mangling, 8 bits */
        cfsetispeed(&t, B115200);
        cfsetospeed(&t, B115200);
        tcsetattr(p->slave, TCSANOW, &t);
    }
    fcntl(p->master, F_SETFL, fcntl(p->master, F_GETFL) | O_NONBLOCK);
    fcntl(p->master, F_SETFD, FD_CLOEXEC);
    fcntl(p->slave, F_SETFD, FD_CLOEXEC);
    if (link && *link) {
        unlink(link);
        if (symlink(p->path, link) < 0) {
            perror("fingertip-sim: symlink");
            return -1;
        }
        snprintf(p->link, sizeof(p->link), "%s", link);
    }
    return 0;
}

static void xoff_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pty_bridge_t *p = param;
    if (value && !p->xoff)
        p->xoffs++;
    p->xoff = value != 0;
}

static void feed(pty_bridge_t *p);

static void xon_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    pty_bridge_t *p = param;
    p->xoff = false;
    feed(p);
}

static void output_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pty_bridge_t *p = param;
    if (ring_put(&p->tx, (uint8_t)value))
        p->from_fw++;
    else
        p->tx_dropped++;    /* nobody reads the pty and 64 KiB piled up */
}

static void *find_uart0(avr_t *avr)
{
    for (avr_io_t *io = avr->io_port; io; io = io->next)
        if (io->kind && !strcmp(io->kind, "uart") && ((avr_uart_t *)io)->name == '0')
            return io;
    return NULL;
}

int pty_attach(pty_bridge_t *p, avr_t *avr)
{
    p->avr = avr;
    p->uart = find_uart0(avr);
    /* Default flags print firmware lines on stdout and usleep() on RX polling: both off. */
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    p->irq_input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_t *out = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
    avr_irq_t *xon = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON);
    avr_irq_t *xoff = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF);
    if (!p->irq_input || !out || !xon || !xoff) {
        fprintf(stderr, "fingertip-sim: this core has no UART0\n");
        return -1;
    }
    avr_irq_register_notify(out, output_notify, p);
    avr_irq_register_notify(xon, xon_notify, p);
    avr_irq_register_notify(xoff, xoff_notify, p);
    return 0;
}

static bool rx_enabled(const pty_bridge_t *p)
{
    return (p->avr->data[UCSR0B_ADDR] >> RXEN0_BIT) & 1;
}

/*
 * Push host bytes into the UART until it says XOFF (its 64-entry fifo is
 * full). simavr then hands them to the firmware one frame time apart. Bytes
 * are held while the receiver is off (boot, reset) instead of being lost.
 */
static void feed(pty_bridge_t *p)
{
    if (!p->avr || !rx_enabled(p))
        return;
    while (!p->xoff && p->rx.len) {
        avr_raise_irq(p->irq_input, ring_get(&p->rx));
        p->to_fw++;
    }
    p->rx_len = p->rx.len;
}

int pty_pollfd(pty_bridge_t *p, struct pollfd *pfd)
{
    short ev = 0;
    if (ring_space(&p->rx))
        ev |= POLLIN;
    if (p->tx.len)
        ev |= POLLOUT;
    pfd->fd = p->master;
    pfd->events = ev;
    pfd->revents = 0;
    return 1;
}

static void read_host(pty_bridge_t *p)
{
    while (ring_space(&p->rx)) {
        uint8_t tmp[4096];
        size_t want = ring_space(&p->rx) < sizeof(tmp) ? ring_space(&p->rx) : sizeof(tmp);
        ssize_t n = read(p->master, tmp, want);
        if (n <= 0)
            return;     /* EAGAIN: nothing now (EIO cannot happen: we hold the slave) */
        for (ssize_t i = 0; i < n; i++)
            ring_put(&p->rx, tmp[i]);
    }
}

static void write_host(pty_bridge_t *p)
{
    while (p->tx.len) {
        ssize_t n = write(p->master, p->tx.buf + p->tx.head, ring_chunk(&p->tx));
        if (n <= 0)
            return;     /* pty buffer full: the host is not reading, keep it for later */
        ring_drop(&p->tx, (size_t)n);
    }
}

void pty_service(pty_bridge_t *p, bool cpu_alive)
{
    read_host(p);
    write_host(p);
    if (!cpu_alive)
        return;
    /* Guard: XOFF is only lifted when firmware polls UCSR0A with an empty fifo. */
    if (p->xoff && p->uart) {
        avr_uart_t *u = p->uart;
        if (u->input.read == u->input.write) {
            p->xoff = false;
            p->xoff_guard++;
        }
    }
    feed(p);
    p->rx_len = p->rx.len;
}

void pty_after_reset(pty_bridge_t *p)
{
    /* The UART fifo was emptied by the reset; pending host bytes wait for RXEN. */
    p->xoff = false;
}

void pty_close(pty_bridge_t *p)
{
    if (p->link[0])
        unlink(p->link);
    if (p->master >= 0)
        close(p->master);
    if (p->slave >= 0)
        close(p->slave);
    p->master = p->slave = -1;
}
