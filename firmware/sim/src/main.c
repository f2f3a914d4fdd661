/*
 * main.c - fingertip-sim: the real firmware ELF in simavr, with simulated
 * HX711s on its pins, UART0 on a private pty and a JSON control channel.
 *
 * The run loop executes instruction slices of SLICE_CYCLES and, between
 * slices, services stdin (commands), the pty and the reply stream with a
 * zero-timeout poll(). While held, it sleeps in poll() instead.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include <sim_elf.h>

#include "sim.h"

/* 100 us of simulated time between two looks at stdin and the pty. */
#define SLICE_CYCLES 1600

static volatile sig_atomic_t got_signal;

static void on_signal(int sig)
{
    got_signal = sig;
}

double sim_real_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* simavr would usleep() while the firmware sleeps: pacing is ours (throttle). */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
    (void)avr;
    (void)how_long;
}

/* --- options --- */

typedef struct options {
    const char *elf;
    const char *mcu;
    const char *link;
    uint64_t f_cpu;
    int channels;
    uint64_t seed;
    double noise;
    double throttle;
    bool run;
    uint32_t dout_delay;
    bool verbose;
} options_t;

static void usage(FILE *f)
{
    fprintf(f,
            "usage: fingertip-sim [options] FIRMWARE.elf\n"
            "  -n, --channels N      simulated HX711s on the fixed pin map, 1..16 (default 4)\n"
            "      --run             start running at once (default: held until `go`)\n"
            "      --throttle F|off  pace to F x real time (default off = free-running)\n"
            "      --seed N          noise seed (default 1)\n"
            "      --noise SIGMA     Gaussian noise on every channel, counts (default 0)\n"
            "      --dout-delay C    cycles from the SCK-rising write to DOUT valid (default 4;\n"
            "                        datasheet t2 <= 0.1 us after a 2-cycle SBI; 0 = instant)\n"
            "      --link PATH       also make PATH a symlink to the pty (removed on exit)\n"
            "  -m, --mcu NAME        simavr core (default atmega328p)\n"
            "  -f, --freq HZ         CPU clock (default 16000000)\n"
            "  -v, --verbose         log commands on stderr\n"
            "  -h, --help\n"
            "Commands on stdin, one JSON line per reply on stdout: see firmware/sim/README.md.\n");
}

static int parse_options(int argc, char **argv, options_t *o)
{
    static const struct option longopts[] = {
        {"channels", required_argument, 0, 'n'}, {"run", no_argument, 0, 'r'},
        {"throttle", required_argument, 0, 't'}, {"seed", required_argument, 0, 's'},
        {"noise", required_argument, 0, 'N'},    {"dout-delay", required_argument, 0, 'd'},
        {"link", required_argument, 0, 'l'},     {"mcu", required_argument, 0, 'm'},
        {"freq", required_argument, 0, 'f'},     {"verbose", no_argument, 0, 'v'},
        {"help", no_argument, 0, 'h'},           {0, 0, 0, 0},
    };
    *o = (options_t){.mcu = "atmega328p", .f_cpu = 16000000, .channels = 4, .seed = 1, .dout_delay = 4};
    int c;
    while ((c = getopt_long(argc, argv, "n:m:f:vh", longopts, NULL)) != -1) {
        switch (c) {
        case 'n': o->channels = atoi(optarg); break;
        case 'r': o->run = true; break;
        case 't': o->throttle = strcasecmp(optarg, "off") ? atof(optarg) : 0.0; break;
        case 's': o->seed = strtoull(optarg, NULL, 0); break;
        case 'N': o->noise = atof(optarg); break;
        case 'd': o->dout_delay = (uint32_t)strtoul(optarg, NULL, 0); break;
        case 'l': o->link = optarg; break;
        case 'm': o->mcu = optarg; break;
        case 'f': o->f_cpu = strtoull(optarg, NULL, 0); break;
        case 'v': o->verbose = true; break;
        case 'h': usage(stdout); exit(0);
        default: usage(stderr); return -1;
        }
    }
    if (optind != argc - 1) {
        usage(stderr);
        return -1;
    }
    o->elf = argv[optind];
    if (o->channels < 1 || o->channels > HX711_MAX_CHANNELS) {
        fprintf(stderr, "fingertip-sim: --channels must be 1..%d\n", HX711_MAX_CHANNELS);
        return -1;
    }
    if (o->throttle < 0 || o->noise < 0 || o->f_cpu < 1000) {
        fprintf(stderr, "fingertip-sim: bad --throttle, --noise or --freq\n");
        return -1;
    }
    return 0;
}

/* --- setup --- */

/*
 * libsimavr printf()s to stdout ("Loaded ...", UART baud lines...). Keep the
 * real stdout for replies only and point fd 1 at stderr for everyone else.
 */
static int take_reply_fd(void)
{
    fflush(stdout);
    int fd = dup(STDOUT_FILENO);
    if (fd < 0 || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
        perror("fingertip-sim: dup");
        return -1;
    }
    fcntl(fd, F_SETFD, FD_CLOEXEC);
    setvbuf(stdout, NULL, _IOLBF, 0);
    return fd;
}

static void install_signals(void)
{
    struct sigaction sa = {.sa_handler = on_signal};
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    /*
     * No PR_SET_PDEATHSIG: it fires when the parent *thread* exits, which
     * kills the harness under threaded test runners. A dead parent closes
     * our stdin instead, and EOF ends the run.
     */
}

/* The ELF image: libsimavr allocates it and never frees it (freed at exit). */
static elf_firmware_t fw;

static void free_firmware(void)
{
    free(fw.flash);
    free(fw.eeprom);
    free(fw.fuse);
    free(fw.lockbits);
#if ELF_SYMBOLS
    for (uint32_t i = 0; i < fw.symbolcount; i++)
        free(fw.symbol[i]);
    free(fw.symbol);
#endif
    memset(&fw, 0, sizeof(fw));
}

static int load_core(sim_t *s, const options_t *o)
{
    s->avr = avr_make_mcu_by_name(o->mcu);
    if (!s->avr)
        return -1;
    memset(&fw, 0, sizeof(fw));
    if (elf_read_firmware(o->elf, &fw) != 0) {
        fprintf(stderr, "fingertip-sim: cannot load %s\n", o->elf);
        return -1;
    }
    snprintf(fw.mmcu, sizeof(fw.mmcu), "%s", o->mcu);
    fw.frequency = (uint32_t)o->f_cpu;
    avr_init(s->avr);
    avr_load_firmware(s->avr, &fw);
    s->avr->frequency = (uint32_t)o->f_cpu;
    s->avr->sleep = no_sleep;
    s->f_cpu = o->f_cpu;
    return 0;
}

static int setup(sim_t *s, const options_t *o, int reply_fd)
{
    memset(s, 0, sizeof(*s));
    reply_init(&s->out, reply_fd);
    events_init(&s->events);
    s->elf_path = o->elf;
    s->seed = o->seed;
    s->throttle = o->throttle;
    s->verbose = o->verbose;
    if (load_core(s, o))
        return -1;
    s->stats.f_cpu = s->f_cpu;
    stats_reset(&s->stats, sim_now(s));
    if (pty_open(&s->pty, o->link) || pty_attach(&s->pty, s->avr))
        return -1;
    if (bus_attach(s, o->channels, o->dout_delay) || latency_attach(s))
        return -1;
    for (int i = 0; i < o->channels; i++)
        s->bus.chip[i].sigma = o->noise;
    s->run = o->run ? RUN_FREE : RUN_HELD;
    s->thr_real0 = sim_real_seconds();
    s->thr_cyc0 = sim_now(s);
    control_hello(s);
    return 0;
}

/* --- run loop --- */

static bool cpu_usable(const sim_t *s)
{
    return !s->cpu_gone && s->avr->state != cpu_Crashed;
}

/* Commands, pty bytes and replies; waits up to timeout_ms for any of them. */
static void service(sim_t *s, int timeout_ms)
{
    struct pollfd pfd[3];
    int n = 0, in_idx = -1;
    if (!s->stdin_eof) {
        in_idx = n;
        pfd[n++] = (struct pollfd){.fd = STDIN_FILENO, .events = POLLIN};
    }
    n += pty_pollfd(&s->pty, &pfd[n]);
    if (reply_pending(&s->out))
        pfd[n++] = (struct pollfd){.fd = s->out.fd, .events = POLLOUT};
    if (poll(pfd, (nfds_t)n, timeout_ms) < 0 && errno != EINTR)
        return;
    if (in_idx >= 0 && (pfd[in_idx].revents & (POLLIN | POLLHUP | POLLERR))) {
        char buf[65536];
        ssize_t r = read(STDIN_FILENO, buf, sizeof(buf));
        if (r > 0)
            control_feed(s, buf, (size_t)r);
        else if (r == 0 || (errno != EINTR && errno != EAGAIN))
            s->stdin_eof = true;
    }
    pty_service(&s->pty, cpu_usable(s));
    control_process(s);
    /* EOF on stdin ends the run once every command before it has been answered. */
    if (s->stdin_eof && !control_blocked(s) && !control_has_line() && !s->quit) {
        s->quit = true;
        s->quit_reason = "eof";
    }
    reply_flush(&s->out, false);
}

static void cpu_stopped(sim_t *s, int state)
{
    if (state == cpu_Done) {
        /* simavr already called avr_terminate(): the core's memory is gone. */
        s->gone_at = s->avr->cycle + s->cyc_offset;
        s->cpu_gone = true;
        control_cpu_event(s, "done");
    } else {
        control_cpu_event(s, "crashed");
    }
    s->run = RUN_HELD;
}

static void run_slice(sim_t *s)
{
    avr_t *avr = s->avr;
    uint64_t start = avr->cycle;
    uint64_t end = start + SLICE_CYCLES;
    if (s->until_active && s->until_at - s->cyc_offset < end)
        end = s->until_at - s->cyc_offset;
    double t0 = sim_real_seconds();
    int state = cpu_Running;
    while (avr->cycle < end) {
        state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed)
            break;
    }
    s->real_running += sim_real_seconds() - t0;
    s->cyc_running += avr->cycle - start;
    if (state == cpu_Done || state == cpu_Crashed)
        cpu_stopped(s, state);
    else if (s->until_active && sim_now(s) >= s->until_at)
        control_until_reached(s);
}

double sim_due_seconds(const sim_t *s)
{
    double sim_s = (double)(sim_now(s) - s->thr_cyc0) / (double)s->f_cpu;
    return s->thr_real0 + sim_s / s->throttle;
}

/* Throttled: wait (serving I/O) until real time catches up with simulated time. */
static void throttle_wait(sim_t *s)
{
    if (s->throttle <= 0)
        return;
    double ahead = sim_due_seconds(s) - sim_real_seconds();
    if (ahead > 0.001)
        service(s, (int)(ahead * 1000.0));
}

static const char *signal_reason(int sig)
{
    return sig == SIGINT ? "sigint" : sig == SIGHUP ? "sighup" : "sigterm";
}

static void run(sim_t *s)
{
    while (!s->quit) {
        if (got_signal) {
            s->quit = true;
            s->quit_reason = signal_reason(got_signal);
            break;
        }
        if (s->out.broken) {
            s->quit = true;
            s->quit_reason = "reply stream closed";
            break;
        }
        if (s->run == RUN_FREE && cpu_usable(s)) {
            double w0 = sim_real_seconds();
            run_slice(s);
            service(s, 0);
            throttle_wait(s);
            s->wall_running += sim_real_seconds() - w0;
        } else {
            service(s, 100);
        }
    }
}

static void shutdown_sim(sim_t *s)
{
    control_exit_report(s);
    reply_flush(&s->out, true);
    pty_close(&s->pty);
    if (!s->cpu_gone)
        avr_terminate(s->avr);
    free_firmware();
    events_free(&s->events);
    reply_free(&s->out);
}

int main(int argc, char **argv)
{
    options_t o;
    if (parse_options(argc, argv, &o))
        return 2;
    int reply_fd = take_reply_fd();
    if (reply_fd < 0)
        return 1;
    install_signals();
    static sim_t sim;
    if (setup(&sim, &o, reply_fd)) {
        reply_t *r = &sim.out;
        reply_init(r, reply_fd);
        jobj(r);
        jstr(r, "event", "error");
        jstr(r, "error", "setup failed, see stderr");
        jend(r);
        reply_flush(r, true);
        return 1;
    }
    reply_flush(&sim.out, false);
    run(&sim);
    shutdown_sim(&sim);
    return 0;
}
