/*
 * control.c - the line-based control protocol (documented in README.md).
 *
 * One command per line on stdin; exactly one single-line JSON reply per
 * command on the reply stream, in order. Lines with an "event" key are
 * asynchronous notices (cpu stopped, exit) and never replace a reply.
 * `until`/`step` defer their reply until the simulated time is reached and
 * block the commands behind them, so replies stay in command order.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "sim.h"

#define MAX_TOKENS (HX711_MAX_CHANNELS + 4)

typedef struct cmd {
    const char *name;
    int ntok;
    char *tok[MAX_TOKENS];
} cmd_t;

/* --- input line buffer (lives here: only the protocol needs it) --- */

static char *inbuf;
static size_t inlen, incap;

void control_feed(sim_t *s, const char *buf, size_t len)
{
    (void)s;
    if (inlen + len + 1 > incap) {
        size_t cap = incap ? incap : 8192;
        while (inlen + len + 1 > cap)
            cap *= 2;
        char *nb = realloc(inbuf, cap);
        if (!nb) {
            fprintf(stderr, "fingertip-sim: out of memory for commands\n");
            exit(3);
        }
        inbuf = nb;
        incap = cap;
    }
    memcpy(inbuf + inlen, buf, len);
    inlen += len;
}

bool control_blocked(const sim_t *s)
{
    return s->until_active;
}

bool control_has_line(void)
{
    return inlen && memchr(inbuf, '\n', inlen);
}

/* --- reply helpers --- */

static void begin(sim_t *s, const char *cmd, bool ok)
{
    jobj(&s->out);
    jbool(&s->out, "ok", ok);
    jstr(&s->out, "cmd", cmd);
}

static void fail(sim_t *s, const char *cmd, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void fail(sim_t *s, const char *cmd, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof(msg), fmt, ap);
    va_end(ap);
    begin(s, cmd, false);
    jstr(&s->out, "error", msg);
    jend(&s->out);
}

static void ok_simple(sim_t *s, const char *cmd)
{
    begin(s, cmd, true);
    jend(&s->out);
}

static void put_time(sim_t *s)
{
    uint64_t now = sim_now(s);
    juint(&s->out, "cycle", now);
    jfix(&s->out, "t_us", sim_cycles_to_us(s, now), 4);
}

/* --- argument parsing --- */

/* "3", "3a", "3b" or "*" (all channels, returned as -1). */
static int parse_ch(sim_t *s, const char *t, int *ch, bool *input_b)
{
    *input_b = false;
    if (!strcmp(t, "*") || !strcasecmp(t, "all")) {
        *ch = -1;
        return 0;
    }
    char *end;
    errno = 0;
    long v = strtol(t, &end, 10);
    if (end == t || errno)
        return -1;
    if (*end == 'b' || *end == 'B') {
        *input_b = true;
        end++;
    } else if (*end == 'a' || *end == 'A') {
        end++;
    }
    if (*end || v < 0 || v >= s->bus.nch)
        return -1;
    *ch = (int)v;
    return 0;
}

/* parse_ch() with a precise error reply; returns nonzero when it replied. */
static int want_ch(sim_t *s, cmd_t *c, const char *t, int *ch, bool *input_b)
{
    if (!parse_ch(s, t, ch, input_b))
        return 0;
    fail(s, c->name, "bad channel '%s': 0..%d with optional a/b suffix, or *", t, s->bus.nch - 1);
    return 1;
}

static int parse_i64(const char *t, int64_t *v)
{
    char *end;
    errno = 0;
    long long x = strtoll(t, &end, 0);
    if (end == t || *end || errno)
        return -1;
    *v = x;
    return 0;
}

static int parse_f64(const char *t, double *v)
{
    char *end;
    errno = 0;
    double x = strtod(t, &end);
    if (end == t || *end || errno || !isfinite(x))
        return -1;
    *v = x;
    return 0;
}

static int parse_us(sim_t *s, const char *t, uint64_t *cycles)
{
    double us;
    if (parse_f64(t, &us) || us < 0)
        return -1;
    *cycles = (uint64_t)llround(us * (double)s->f_cpu / 1e6);
    return 0;
}

/* --- commands --- */

static void cmd_time(sim_t *s, cmd_t *c)
{
    begin(s, c->name, true);
    put_time(s);
    /* Throttled: the host time (CLOCK_MONOTONIC, Python's time.monotonic()) this simulated
     * instant is due at by the pacing: the ideal crystal's time, free of the reply's travel
     * time (simavr runs up to a millisecond ahead of it, behind when starved). */
    if (s->throttle > 0)
        jfix(&s->out, "due_s", sim_due_seconds(s), 6);
    jbool(&s->out, "held", s->run == RUN_HELD);
    jnum(&s->out, "throttle", s->throttle);
    jend(&s->out);
}

static void set_input(sim_t *s, int ch, bool input_b, int64_t v)
{
    int lo = ch < 0 ? 0 : ch, hi = ch < 0 ? s->bus.nch - 1 : ch;
    for (int i = lo; i <= hi; i++)
        bus_apply_now(s, i, input_b, v);
}

static void cmd_set(sim_t *s, cmd_t *c)
{
    int ch;
    bool b;
    int64_t v;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: set <ch>[b]|* <value>");
    if (want_ch(s, c, c->tok[0], &ch, &b))
        return;
    if (parse_i64(c->tok[1], &v))
        return fail(s, c->name, "bad value '%s' (integer counts, 0x.. allowed)", c->tok[1]);
    set_input(s, ch, b, v);
    begin(s, c->name, true);
    put_time(s);
    jend(&s->out);
}

/* Queue one value; a time already past is applied now and reported as late. */
static bool schedule(sim_t *s, uint64_t at, int ch, bool b, int64_t v)
{
    if (at <= sim_now(s)) {
        set_input(s, ch, b, v);
        s->stats.events_late++;
        return true;
    }
    int lo = ch < 0 ? 0 : ch, hi = ch < 0 ? s->bus.nch - 1 : ch;
    bool moved = false;
    for (int i = lo; i <= hi; i++)
        moved |= events_push(&s->events, at, i, b, v);
    if (moved)
        bus_events_rearm(s);
    return false;
}

static void cmd_at(sim_t *s, cmd_t *c)
{
    uint64_t at;
    int ch;
    bool b;
    int64_t v;
    if (c->ntok != 3 || parse_us(s, c->tok[0], &at))
        return fail(s, c->name, "usage: at <t_us> <ch>[b]|* <value>");
    if (want_ch(s, c, c->tok[1], &ch, &b))
        return;
    if (parse_i64(c->tok[2], &v))
        return fail(s, c->name, "bad value '%s' (integer counts, 0x.. allowed)", c->tok[2]);
    bool late = schedule(s, at, ch, b, v);
    begin(s, c->name, true);
    jbool(&s->out, "late", late);
    jend(&s->out);
}

static void cmd_row(sim_t *s, cmd_t *c)
{
    uint64_t at;
    if (c->ntok < 2 || c->ntok > s->bus.nch + 1 || parse_us(s, c->tok[0], &at))
        return fail(s, c->name, "usage: row <t_us> <v0> [<v1> ...] (at most %d values, '-' = unchanged)",
                    s->bus.nch);
    int64_t v[HX711_MAX_CHANNELS];
    for (int i = 1; i < c->ntok; i++)
        if (strcmp(c->tok[i], "-") && parse_i64(c->tok[i], &v[i - 1]))
            return fail(s, c->name, "bad value '%s'", c->tok[i]);
    bool late = false;
    for (int i = 1; i < c->ntok; i++)
        if (strcmp(c->tok[i], "-"))
            late |= schedule(s, at, i - 1, false, v[i - 1]);
    begin(s, c->name, true);
    jbool(&s->out, "late", late);
    jend(&s->out);
}

static void cmd_noise(sim_t *s, cmd_t *c)
{
    int ch;
    bool b;
    double sigma;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: noise <ch>|* <sigma_counts>");
    if (want_ch(s, c, c->tok[0], &ch, &b))
        return;
    if (parse_f64(c->tok[1], &sigma) || sigma < 0)
        return fail(s, c->name, "bad sigma '%s' (counts >= 0)", c->tok[1]);
    for (int i = 0; i < s->bus.nch; i++)
        if (ch < 0 || ch == i)
            s->bus.chip[i].sigma = sigma;
    ok_simple(s, c->name);
}

static void cmd_seed(sim_t *s, cmd_t *c)
{
    int64_t seed;
    if (c->ntok != 1 || parse_i64(c->tok[0], &seed))
        return fail(s, c->name, "usage: seed <integer>");
    bus_reseed(s, (uint64_t)seed);
    ok_simple(s, c->name);
}

static void cmd_clock(sim_t *s, cmd_t *c)
{
    int ch;
    bool b;
    double ppm;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: clock <ch>|* <ppm>");
    if (want_ch(s, c, c->tok[0], &ch, &b))
        return;
    if (parse_f64(c->tok[1], &ppm) || fabs(ppm) > 1e5)
        return fail(s, c->name, "bad ppm '%s' (|ppm| <= 100000)", c->tok[1]);
    for (int i = 0; i < s->bus.nch; i++)
        if (ch < 0 || ch == i)
            s->bus.chip[i].ppm = ppm;   /* takes effect from the next period */
    ok_simple(s, c->name);
}

static void cmd_chip(sim_t *s, cmd_t *c)
{
    int ch;
    bool b;
    hx711_mode_t mode;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: chip <ch>|* ok|absent|stuck_low");
    if (want_ch(s, c, c->tok[0], &ch, &b))
        return;
    if (hx711_mode_parse(c->tok[1], &mode))
        return fail(s, c->name, "bad mode '%s' (ok|absent|stuck_low)", c->tok[1]);
    if (s->cpu_gone)
        return fail(s, c->name, "the simulated CPU has stopped");
    for (int i = 0; i < s->bus.nch; i++)
        if (ch < 0 || ch == i)
            bus_set_mode(s, i, mode);
    ok_simple(s, c->name);
}

static void cmd_fault(sim_t *s, cmd_t *c)
{
    int ch;
    bool b;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: fault <ch>|* ok|reversed|loose|open");
    if (want_ch(s, c, c->tok[0], &ch, &b))
        return;
    for (int i = 0; i < s->bus.nch; i++)
        if ((ch < 0 || ch == i) && hx711_set_fault(&s->bus.chip[i], c->tok[1]))
            return fail(s, c->name, "bad fault '%s' (ok|reversed|loose|open)", c->tok[1]);
    ok_simple(s, c->name);
}

/* Two DOUT wires swapped: each channel's bridge now shows on the other's pin. */
static void cmd_swap(sim_t *s, cmd_t *c)
{
    int a, b2;
    bool ia, ib;
    if (c->ntok != 2)
        return fail(s, c->name, "usage: swap <ch> <ch>");
    if (want_ch(s, c, c->tok[0], &a, &ia) || want_ch(s, c, c->tok[1], &b2, &ib))
        return;
    if (a < 0 || b2 < 0)
        return fail(s, c->name, "swap takes two channel numbers, not *");
    hx711_t *ca = &s->bus.chip[s->bus.route[a]], *cb = &s->bus.chip[s->bus.route[b2]];
    int64_t ia0 = ca->in_a, ib0 = ca->in_b;   /* what each pin shows changes at once */
    ca->in_a = cb->in_a;
    ca->in_b = cb->in_b;
    cb->in_a = ia0;
    cb->in_b = ib0;
    int8_t t = s->bus.route[a];
    s->bus.route[a] = s->bus.route[b2];
    s->bus.route[b2] = t;
    ok_simple(s, c->name);
}

static const char *gain_name(hx711_gain_t g)
{
    return g == HX711_GAIN_A128 ? "A128" : g == HX711_GAIN_A64 ? "A64" : "B32";
}

static void cmd_chips(sim_t *s, cmd_t *c)
{
    uint64_t now = sim_now(s);
    begin(s, c->name, true);
    put_time(s);
    jint(&s->out, "sck", s->bus.sck);
    jint(&s->out, "rate_sps", s->bus.rate80 ? 80 : 10);
    jarr_key(&s->out, "chips");
    for (int i = 0; i < s->bus.nch; i++) {
        const hx711_t *h = &s->bus.chip[i];
        jobj_elem(&s->out);
        jint(&s->out, "ch", i);
        jstr(&s->out, "pin", bus_pin_name(i));
        jstr(&s->out, "mode", hx711_mode_name(h->mode));
        jstr(&s->out, "fault", hx711_fault_name(h));
        jint(&s->out, "route", s->bus.route[i]);
        jbool(&s->out, "powered", h->powered);
        jbool(&s->out, "ready", h->ready);
        jint(&s->out, "pulses", h->pulses);
        jint(&s->out, "dout", s->bus.dout_level[i]);
        jint(&s->out, "pin_level", bus_pin_level(s, i));
        jstr(&s->out, "gain", gain_name(h->gain));
        jint(&s->out, "in_a", h->in_a);
        jint(&s->out, "in_b", h->in_b);
        jnum(&s->out, "sigma", h->sigma);
        jnum(&s->out, "ppm", h->ppm);
        jint(&s->out, "last", h->last_value);
        if (h->next_conv)
            jfix(&s->out, "next_conv_in_us", sim_cycles_to_us(s, h->next_conv > now ? h->next_conv - now : 0), 4);
        else
            jnull(&s->out, "next_conv_in_us");
        jend(&s->out);
    }
    jend(&s->out);
    jend(&s->out);
}

/* Why the CPU cannot run, or NULL. A crash can be undone by `reset`; cpu_Done cannot. */
static const char *cpu_blocker(const sim_t *s)
{
    if (s->cpu_gone)
        return "the simulated CPU has stopped for good (slept with interrupts off)";
    if (s->avr->state == cpu_Crashed)
        return "the simulated CPU crashed: send reset";
    return NULL;
}

static void start_running(sim_t *s)
{
    s->run = RUN_FREE;
    s->thr_real0 = sim_real_seconds();
    s->thr_cyc0 = sim_now(s);
}

static void cmd_go(sim_t *s, cmd_t *c)
{
    if (cpu_blocker(s))
        return fail(s, c->name, "%s", cpu_blocker(s));
    start_running(s);
    begin(s, c->name, true);
    put_time(s);
    jend(&s->out);
}

static void cmd_hold(sim_t *s, cmd_t *c)
{
    s->run = RUN_HELD;
    begin(s, c->name, true);
    put_time(s);
    jend(&s->out);
}

static void cmd_until(sim_t *s, cmd_t *c, bool relative)
{
    uint64_t t;
    if (c->ntok != 1 || parse_us(s, c->tok[0], &t))
        return fail(s, c->name, relative ? "usage: step <us>" : "usage: until <t_us>");
    if (cpu_blocker(s))
        return fail(s, c->name, "%s", cpu_blocker(s));
    s->until_at = relative ? sim_now(s) + t : t;
    s->until_cmd = relative ? "step" : "until";
    s->until_active = true;
    if (sim_now(s) >= s->until_at) {
        control_until_reached(s);
        return;
    }
    start_running(s);
}

void control_until_reached(sim_t *s)
{
    s->until_active = false;
    s->run = RUN_HELD;
    begin(s, s->until_cmd, true);
    put_time(s);
    jbool(&s->out, "held", true);
    jend(&s->out);
}

void control_reset_mcu(sim_t *s)
{
    avr_t *avr = s->avr;
    uint64_t before = avr->cycle;
    avr_reset(avr);
    if (avr->cycle < before)
        s->cyc_offset += before - avr->cycle;    /* keep harness time monotonic */
    if (avr->state == cpu_Crashed || avr->state == cpu_Stopped)
        avr->state = cpu_Running;
    bus_after_reset(s);
    pty_after_reset(&s->pty);
}

static void cmd_reset(sim_t *s, cmd_t *c)
{
    if (s->cpu_gone)
        return fail(s, c->name, "%s", cpu_blocker(s));
    control_reset_mcu(s);
    begin(s, c->name, true);
    put_time(s);
    jend(&s->out);
}

static void cmd_throttle(sim_t *s, cmd_t *c)
{
    double f = 0;
    if (c->ntok != 1 || (strcasecmp(c->tok[0], "off") && (parse_f64(c->tok[0], &f) || f < 0)))
        return fail(s, c->name, "usage: throttle <factor>|off");
    s->throttle = f;
    s->thr_real0 = sim_real_seconds();
    s->thr_cyc0 = sim_now(s);
    begin(s, c->name, true);
    jnum(&s->out, "throttle", f);
    jend(&s->out);
}

static void cmd_stats(sim_t *s, cmd_t *c)
{
    begin(s, c->name, true);
    stats_write(s, &s->out, "stats");
    jend(&s->out);
}

static void cmd_stats_reset(sim_t *s, cmd_t *c)
{
    stats_reset(&s->stats, sim_now(s));
    latency_reset(&s->latency);
    for (int i = 0; i < s->bus.nch; i++)
        memset(&s->bus.chip[i].n, 0, sizeof(s->bus.chip[i].n));
    s->pty.to_fw = s->pty.from_fw = s->pty.tx_dropped = s->pty.xoff_guard = s->pty.xoffs = 0;
    s->cyc_running = 0;
    s->real_running = 0;
    s->wall_running = 0;
    begin(s, c->name, true);
    put_time(s);
    jend(&s->out);
}

static void cmd_quit(sim_t *s, cmd_t *c)
{
    ok_simple(s, c->name);
    s->quit = true;
    s->quit_reason = "quit";
}

static void cmd_ping(sim_t *s, cmd_t *c)
{
    ok_simple(s, c->name);
}

typedef struct {
    const char *name;
    void (*fn)(sim_t *, cmd_t *);
} entry_t;

static void cmd_until_abs(sim_t *s, cmd_t *c) { cmd_until(s, c, false); }
static void cmd_step(sim_t *s, cmd_t *c) { cmd_until(s, c, true); }

static const entry_t table[] = {
    {"ping", cmd_ping},       {"time", cmd_time},     {"set", cmd_set},
    {"at", cmd_at},           {"row", cmd_row},       {"noise", cmd_noise},
    {"seed", cmd_seed},       {"clock", cmd_clock},   {"chip", cmd_chip},
    {"chips", cmd_chips},     {"go", cmd_go},         {"hold", cmd_hold},
    {"until", cmd_until_abs}, {"step", cmd_step},     {"reset", cmd_reset},
    {"throttle", cmd_throttle}, {"stats", cmd_stats}, {"stats_reset", cmd_stats_reset},
    {"fault", cmd_fault},     {"swap", cmd_swap},     {"quit", cmd_quit},
};

static void execute(sim_t *s, char *line)
{
    cmd_t c = {0};
    char *save = NULL;
    char *t = strtok_r(line, " \t\r", &save);
    if (!t || *t == '#')
        return;     /* blank lines and comments get no reply */
    c.name = t;
    while ((t = strtok_r(NULL, " \t\r", &save))) {
        if (c.ntok == MAX_TOKENS)
            return fail(s, c.name, "too many arguments");
        c.tok[c.ntok++] = t;
    }
    if (s->verbose)
        fprintf(stderr, "fingertip-sim: < %s (%d args)\n", c.name, c.ntok);
    for (unsigned i = 0; i < sizeof(table) / sizeof(table[0]); i++)
        if (!strcmp(c.name, table[i].name)) {
            table[i].fn(s, &c);
            return;
        }
    fail(s, c.name, "unknown command");
}

void control_process(sim_t *s)
{
    size_t pos = 0;
    while (!s->quit && !control_blocked(s) && pos < inlen) {
        char *nl = memchr(inbuf + pos, '\n', inlen - pos);
        if (!nl)
            break;
        *nl = 0;
        execute(s, inbuf + pos);
        pos = (size_t)(nl - inbuf) + 1;
    }
    if (pos) {
        memmove(inbuf, inbuf + pos, inlen - pos);
        inlen -= pos;
    }
}

void control_hello(sim_t *s)
{
    jobj(&s->out);
    jstr(&s->out, "pty", s->pty.path);
    jint(&s->out, "version", SIM_PROTOCOL_VERSION);
    jint(&s->out, "channels", s->bus.nch);
    juint(&s->out, "f_cpu", s->f_cpu);
    jbool(&s->out, "held", s->run == RUN_HELD);
    jint(&s->out, "pid", getpid());
    jstr(&s->out, "elf", s->elf_path);
    jend(&s->out);
}

void control_cpu_event(sim_t *s, const char *state)
{
    jobj(&s->out);
    jstr(&s->out, "event", "cpu");
    jstr(&s->out, "state", state);
    put_time(s);
    jend(&s->out);
    if (s->until_active) {
        s->until_active = false;
        fail(s, s->until_cmd, "the simulated CPU stopped (%s) before the target time", state);
    }
}

void control_exit_report(sim_t *s)
{
    jobj(&s->out);
    jstr(&s->out, "event", "exit");
    jstr(&s->out, "reason", s->quit_reason ? s->quit_reason : "unknown");
    stats_write(s, &s->out, "stats");
    jend(&s->out);
}
