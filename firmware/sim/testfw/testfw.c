/*
 * testfw.c - tiny test firmware for the fingertip-sim harness (not the product firmware).
 *
 * Plain avr-gcc C for the ATmega328P at 16 MHz, no Arduino core. It reads N
 * HX711s in parallel on the project's pin map with direct register access
 * and prints what it got as text on UART0 at 115200 baud, so selftest.py can
 * check the harness end to end.
 *
 *   SCK = PB4 (D12), RATE = PB5 (D13, high = 80 SPS)
 *   DOUT ch 0..5 = PD2..PD7, ch 6..11 = PC0..PC5, ch 12..15 = PB0..PB3
 *
 * Output lines:  "HELLO testfw"          at boot
 *                "D <seq> <v0> .. <vN-1>" one per parallel read (signed decimal)
 *                "T <hexmask>"           no all-ready within 300 ms: DOUT-high channels
 *                "OK <cmd>" / "E<text>"  command replies
 * Commands (one per line): N<n> channels, R0/R1 rate, G25/G26/G27 pulses,
 *                F1/F0 sample DOUT right after SCK rise (too early) / after 2 nops,
 *                P<us> hold SCK high for <us> between reads (deliberate power-down),
 *                L<us> stretch pulse 12 of the next read to <us> (in-read violation), Q/V quiet/verbose,
 *                E<text> echo, Z sleep with interrupts off (ends the simulation).
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <util/delay.h>

#define SCK_BIT PB4
#define RATE_BIT PB5

/* --- UART, interrupt driven both ways (ISRs run during reads, as in real firmware) --- */

#define TX_SIZE 256
#define RX_SIZE 128

static volatile uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_head, tx_tail;     /* uint8_t indices wrap at 256 */
static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head, rx_tail;

ISR(USART_RX_vect)
{
    uint8_t c = UDR0;
    uint8_t next = (uint8_t)((rx_head + 1) % RX_SIZE);
    if (next != rx_tail) {
        rx_buf[rx_head] = c;
        rx_head = next;
    }
}

ISR(USART_UDRE_vect)
{
    if (tx_head == tx_tail) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx_buf[tx_tail++];
}

static void uart_init(void)
{
    UCSR0A = _BV(U2X0);
    UBRR0 = 16;     /* 115200 with U2X at 16 MHz, as the Arduino core does */
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

static void putc_(char c)
{
    while ((uint8_t)(tx_head + 1) == tx_tail)
        ;
    tx_buf[tx_head] = (uint8_t)c;
    cli();
    tx_head++;
    UCSR0B |= _BV(UDRIE0);
    sei();
}

static void puts_(const char *s)
{
    while (*s)
        putc_(*s++);
}

static void putl(int32_t v)
{
    char b[12];
    ltoa(v, b, 10);
    puts_(b);
}

static int getc_(void)
{
    if (rx_head == rx_tail)
        return -1;
    uint8_t c = rx_buf[rx_tail];
    rx_tail = (uint8_t)((rx_tail + 1) % RX_SIZE);
    return c;
}

/* --- milliseconds from Timer1 (another ISR source during reads) --- */

static volatile uint32_t ms;

ISR(TIMER1_COMPA_vect)
{
    ms++;
}

static void timer_init(void)
{
    TCCR1A = 0;
    TCCR1B = _BV(WGM12) | _BV(CS11) | _BV(CS10);   /* CTC, clk/64 */
    OCR1A = 249;                                    /* 1 kHz */
    TIMSK1 = _BV(OCIE1A);
}

static uint32_t millis(void)
{
    cli();
    uint32_t m = ms;
    sei();
    return m;
}

/* --- HX711 bus --- */

static uint8_t nch = 4;
static uint8_t mask_d, mask_c, mask_b;   /* DOUT bits of the active channels */
static uint8_t pulses = 25;
static bool early;                       /* sample DOUT too soon after SCK rise */
static bool quiet;
static uint16_t stretch_us;              /* stretch pulse 12 of the next read (bug demo) */

static void set_channels(uint8_t n)
{
    nch = n;
    mask_d = mask_c = mask_b = 0;
    for (uint8_t ch = 0; ch < n; ch++) {
        if (ch < 6)
            mask_d |= (uint8_t)_BV(ch + 2);
        else if (ch < 12)
            mask_c |= (uint8_t)_BV(ch - 6);
        else
            mask_b |= (uint8_t)_BV(ch - 12);
    }
}

static bool all_ready(void)
{
    return !(PIND & mask_d) && !(PINC & mask_c) && !(PINB & mask_b);
}

static void pins_init(void)
{
    DDRB = _BV(SCK_BIT) | _BV(RATE_BIT);
    /* Pull-ups on every DOUT: the harness must win against them (NOTES.md). */
    PORTB = _BV(RATE_BIT) | 0x0F;
    PORTC = 0x3F;
    PORTD = 0xFC;
}

/* Interrupts are off only while SCK is high: a long ISR there would power the chips down. */
static void pulse_only(void)
{
    cli();
    PORTB |= _BV(SCK_BIT);
    __asm__ __volatile__("nop\n\tnop\n\t");
    PORTB &= (uint8_t)~_BV(SCK_BIT);
    sei();
}

/*
 * One data pulse, sampling all three DOUT ports while SCK is high. Written in
 * asm so the high time is exact: SBI, 2 NOPs (t2: DOUT is valid 0.1 us after
 * the edge), 3 INs, CBI = 7 cycles (0.44 us). The "early" variant omits the
 * NOPs and samples too soon: the harness must then report early samples.
 */
#define PULSE_SAMPLE(NOPS)                                                               \
    __asm__ __volatile__("cli\n\t"                                                       \
                         "sbi %[port], %[bit]\n\t" NOPS "in %[d], %[pind]\n\t"           \
                         "in %[c], %[pinc]\n\t"                                          \
                         "in %[b], %[pinb]\n\t"                                          \
                         "cbi %[port], %[bit]\n\t"                                       \
                         "sei\n\t"                                                       \
                         : [d] "=&r"(pd), [c] "=&r"(pc), [b] "=&r"(pb)                   \
                         : [port] "I"(_SFR_IO_ADDR(PORTB)), [bit] "I"(SCK_BIT),          \
                           [pind] "I"(_SFR_IO_ADDR(PIND)), [pinc] "I"(_SFR_IO_ADDR(PINC)), \
                           [pinb] "I"(_SFR_IO_ADDR(PINB)))

static void shift_in(uint8_t *d, uint8_t *c, uint8_t *b)
{
    uint8_t pd, pc, pb;
    bool too_early = early;
    for (uint8_t i = 0; i < 24; i++) {
        if (i == 11 && stretch_us) {
            /* Deliberately broken read: SCK stays high too long in mid-read. */
            PORTB |= _BV(SCK_BIT);
            for (uint16_t us = stretch_us; us; us--)
                _delay_us(1);
            pd = PIND;
            pc = PINC;
            pb = PINB;
            PORTB &= (uint8_t)~_BV(SCK_BIT);
            stretch_us = 0;
        } else if (too_early)
            PULSE_SAMPLE("");
        else
            PULSE_SAMPLE("nop\n\tnop\n\t");
        d[i] = pd;
        c[i] = pc;
        b[i] = pb;
    }
    for (uint8_t i = 24; i < pulses; i++)
        pulse_only();
}

static int32_t decode(uint8_t ch, const uint8_t *d, const uint8_t *c, const uint8_t *b)
{
    const uint8_t *port = ch < 6 ? d : ch < 12 ? c : b;
    uint8_t bit = ch < 6 ? (uint8_t)(ch + 2) : ch < 12 ? (uint8_t)(ch - 6) : (uint8_t)(ch - 12);
    uint32_t v = 0;
    for (uint8_t i = 0; i < 24; i++)
        v = (v << 1) | ((port[i] >> bit) & 1u);
    if (v & 0x800000UL)
        v |= 0xFF000000UL;      /* sign-extend 24-bit two's complement */
    return (int32_t)v;
}

static void read_and_print(uint32_t seq)
{
    uint8_t d[24], c[24], b[24];
    shift_in(d, c, b);
    if (quiet)
        return;
    puts_("D ");
    putl((int32_t)seq);
    for (uint8_t ch = 0; ch < nch; ch++) {
        putc_(' ');
        putl(decode(ch, d, c, b));
    }
    putc_('\n');
}

static void report_timeout(void)
{
    uint16_t high = 0;
    uint8_t pd = PIND, pc = PINC, pb = PINB;
    for (uint8_t ch = 0; ch < nch; ch++) {
        uint8_t lvl = ch < 6 ? (pd >> (ch + 2)) & 1 : ch < 12 ? (pc >> (ch - 6)) & 1 : (pb >> (ch - 12)) & 1;
        if (lvl)
            high |= (uint16_t)(1u << ch);
    }
    char buf[8];
    puts_("T ");
    utoa(high, buf, 16);
    puts_(buf);
    putc_('\n');
}

/* --- commands --- */

static char line[100];
static uint8_t line_len;

static void hold_sck_high(uint16_t us)
{
    _delay_ms(2);   /* well clear of the last read: a deliberate power-down */
    PORTB |= _BV(SCK_BIT);
    while (us--)
        _delay_us(1);
    PORTB &= (uint8_t)~_BV(SCK_BIT);
}

static void run_command(void)
{
    line[line_len] = 0;
    char op = line[0];
    int arg = atoi(line + 1);
    switch (op) {
    case 'N':
        if (arg >= 1 && arg <= 16)
            set_channels((uint8_t)arg);
        break;
    case 'R':
        if (arg)
            PORTB |= _BV(RATE_BIT);
        else
            PORTB &= (uint8_t)~_BV(RATE_BIT);
        break;
    case 'G':
        if (arg >= 25 && arg <= 27)
            pulses = (uint8_t)arg;
        break;
    case 'F': early = arg != 0; break;
    case 'P': hold_sck_high((uint16_t)arg); break;
    case 'L': stretch_us = (uint16_t)arg; break;
    case 'Z':
        /* Sleep with interrupts off: simavr ends the core (cpu_Done) for good. */
        while (tx_head != tx_tail)
            ;
        cli();
        sleep_enable();
        sleep_cpu();
        break;
    case 'Q': quiet = true; break;
    case 'V': quiet = false; break;
    case 'E':
        puts_(line);
        putc_('\n');
        return;
    default:
        puts_("ERR ");
        puts_(line);
        putc_('\n');
        return;
    }
    puts_("OK ");
    puts_(line);
    putc_('\n');
}

static void poll_commands(void)
{
    int c;
    while ((c = getc_()) >= 0) {
        if (c == '\n') {
            run_command();
            line_len = 0;
        } else if (c != '\r' && line_len < sizeof(line) - 1) {
            line[line_len++] = (char)c;
        }
    }
}

int main(void)
{
    pins_init();
    set_channels(4);
    uart_init();
    timer_init();
    sei();
    puts_("HELLO testfw\n");
    uint32_t seq = 0;
    uint32_t t0 = millis();
    for (;;) {
        poll_commands();
        if (all_ready()) {
            read_and_print(seq++);
            t0 = millis();
        } else if (millis() - t0 > 300) {
            report_timeout();
            t0 = millis();
        }
    }
}
