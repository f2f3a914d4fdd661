/*
 * hx711.c - HX711 state machine (see hx711.h for what is modelled).
 */
#include "hx711.h"

#include <math.h>
#include <string.h>
#include <strings.h>

static void drive(hx711_t *c, int level, bool delayed)
{
    c->ops->drive(c->ops->ctx, c->ch, level, delayed);
}

static void set_next(hx711_t *c, uint64_t at)
{
    c->next_conv = at;
    c->ops->reschedule(c->ops->ctx, c->ch, at);
}

void hx711_init(hx711_t *c, int ch, uint64_t f_cpu, const hx711_ops_t *ops)
{
    memset(c, 0, sizeof(*c));
    c->ch = ch;
    c->mode = HX711_OK;
    c->gain = HX711_GAIN_A128;
    c->f_cpu = f_cpu;
    c->ops = ops;
    c->fault_scale = 1.0;
}

int hx711_set_fault(hx711_t *c, const char *name)
{
    double scale = 1.0;
    int64_t offset = 0;
    if (!strcasecmp(name, "reversed"))
        scale = -1.0;
    else if (!strcasecmp(name, "loose"))
        scale = 0.15;
    else if (!strcasecmp(name, "open"))
        offset = (int64_t)1 << 24;
    else if (strcasecmp(name, "ok"))
        return -1;
    c->fault_scale = scale;
    c->fault_offset = offset;
    c->fault_ref = c->in_a;
    return 0;
}

const char *hx711_fault_name(const hx711_t *c)
{
    if (c->fault_offset)
        return "open";
    return c->fault_scale == 1.0 ? "ok" : c->fault_scale < 0 ? "reversed" : "loose";
}

/* splitmix64: tiny, good enough for test noise, and trivially seedable per chip. */
static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

void hx711_seed(hx711_t *c, uint64_t seed)
{
    /* Each channel gets its own stream so adding channels does not change others. */
    c->rng = seed ^ (0xD1B54A32D192ED03ULL * (uint64_t)(c->ch + 1));
    c->have_spare = false;
}

static double uniform01(uint64_t *s)
{
    return ((double)(rng_next(s) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

static double gaussian(hx711_t *c)
{
    if (c->have_spare) {
        c->have_spare = false;
        return c->spare;
    }
    double u1 = uniform01(&c->rng), u2 = uniform01(&c->rng);
    double r = sqrt(-2.0 * log(u1));
    c->spare = r * sin(2.0 * M_PI * u2);
    c->have_spare = true;
    return r * cos(2.0 * M_PI * u2);
}

uint64_t hx711_period(const hx711_t *c)
{
    double sps = c->rate80 ? 80.0 : 10.0;
    double period = (double)c->f_cpu / sps / (1.0 + c->ppm * 1e-6);
    return period < 1.0 ? 1 : (uint64_t)llround(period);
}

int32_t hx711_code(int64_t input, double noise, hx711_gain_t gain)
{
    /* long double keeps every int64 exact, so noise-free values are bit-exact. */
    long double scale = gain == HX711_GAIN_A128 ? 1.0L : gain == HX711_GAIN_A64 ? 0.5L : 0.25L;
    long double x = ((long double)input + (long double)noise) * scale;
    if (x >= (long double)HX711_MAX_CODE)
        return HX711_MAX_CODE;
    if (x <= (long double)HX711_MIN_CODE)
        return HX711_MIN_CODE;
    return (int32_t)llroundl(x);
}

static void settle(hx711_t *c, uint64_t now)
{
    c->n.settles++;
    set_next(c, now + HX711_SETTLE_PERIODS * hx711_period(c));
}

void hx711_power_up(hx711_t *c, uint64_t now)
{
    if (c->mode != HX711_OK)
        return;
    c->powered = true;
    c->gain = HX711_GAIN_A128;     /* datasheet: reset to channel A, gain 128 */
    c->pulses = 0;
    c->ready = false;
    drive(c, 1, false);
    settle(c, now);
}

void hx711_power_down(hx711_t *c)
{
    if (c->mode != HX711_OK || !c->powered)
        return;
    if (c->pulses > 0 && c->pulses < 25)
        c->n.partial++;
    c->powered = false;
    c->pulses = 0;
    c->ready = false;
    c->n.power_downs++;
    drive(c, 1, false);
    set_next(c, 0);
}

void hx711_set_rate(hx711_t *c, uint64_t now, bool rate80)
{
    if (c->rate80 == rate80)
        return;
    c->rate80 = rate80;
    if (c->mode == HX711_OK && c->powered)
        settle(c, now);
}

void hx711_set_mode(hx711_t *c, uint64_t now, hx711_mode_t mode, bool sck_high)
{
    if (c->mode == mode)
        return;
    c->mode = mode;
    c->powered = false;
    c->pulses = 0;
    c->ready = false;
    set_next(c, 0);
    if (mode == HX711_ABSENT)
        drive(c, 1, false);
    else if (mode == HX711_STUCK_LOW)
        drive(c, 0, false);
    else if (sck_high)
        drive(c, 1, false);       /* revived with SCK high: stays powered down */
    else
        hx711_power_up(c, now);
}

/*
 * A read of 25..27 pulses is only known to be over when the chip must act on
 * it: at pulse 27, or at the next conversion. Returns true when the gain
 * changed, which restarts settling (no data this period).
 */
static bool finish_read(hx711_t *c, uint64_t now)
{
    hx711_gain_t g = (hx711_gain_t)(c->pulses - 24);
    c->pulses = 0;
    if (g == c->gain)
        return false;
    c->gain = g;
    c->n.settles++;
    c->next_conv = now + HX711_SETTLE_PERIODS * hx711_period(c);
    return true;
}

static int32_t sample(hx711_t *c)
{
    int64_t in = c->gain == HX711_GAIN_B32 ? c->in_b : c->in_a;
    double noise = c->sigma > 0.0 ? c->sigma * gaussian(c) : 0.0;
    if (c->fault_scale != 1.0 || c->fault_offset) {
        /* Whole counts in, so the healthy path stays bit-exact. */
        double x = (double)c->fault_ref + c->fault_scale * (double)(in - c->fault_ref);
        in = llround(x) + c->fault_offset;
    }
    return hx711_code(in, noise, c->gain);
}

uint64_t hx711_convert(hx711_t *c, uint64_t now)
{
    /* Called from the host's timer: never call reschedule from here, return instead. */
    if (c->mode != HX711_OK || !c->powered) {
        c->next_conv = 0;
        return 0;
    }
    if (c->pulses > 0 && c->pulses < 25) {
        if (now - c->last_edge < c->f_cpu / 1000000u * HX711_ABANDON_US) {
            /* The output register is busy shifting: this conversion is lost. */
            c->n.missed++;
            c->next_conv = now + hx711_period(c);
            return c->next_conv;
        }
        c->n.partial++;     /* read abandoned long ago: the new conversion replaces it */
        c->pulses = 0;
    }
    if (c->pulses >= 25 && finish_read(c, now))
        return c->next_conv;
    if (c->ready)
        c->n.missed++;    /* previous conversion was never read */
    c->last_value = sample(c);
    c->shift = (uint32_t)c->last_value & 0xFFFFFFu;
    c->ready = true;
    c->n.conversions++;
    drive(c, 0, false);
    c->next_conv = now + hx711_period(c);
    return c->next_conv;
}

void hx711_sck_rise(hx711_t *c, uint64_t now)
{
    if (c->mode != HX711_OK || !c->powered)
        return;
    if (c->pulses == 0 && !c->ready)
        return;   /* not a read for this chip: nothing to shift */
    if (c->pulses >= 27)
        return;   /* extra pulses after 27 are ignored */
    c->pulses++;
    c->last_edge = now;
    if (c->pulses <= 24) {
        drive(c, (int)((c->shift >> (24 - c->pulses)) & 1u), true);
    } else if (c->pulses == 25) {
        c->ready = false;
        c->n.reads++;
        drive(c, 1, true);
    }
}

void hx711_sck_fall(hx711_t *c, uint64_t now)
{
    if (c->mode != HX711_OK || !c->powered)
        return;
    if (c->pulses == 27 && finish_read(c, now))
        set_next(c, c->next_conv);
}

static const char *const mode_names[] = {"ok", "absent", "stuck_low"};

const char *hx711_mode_name(hx711_mode_t m)
{
    return mode_names[m];
}

int hx711_mode_parse(const char *s, hx711_mode_t *out)
{
    static const struct {
        const char *name;
        hx711_mode_t mode;
    } alias[] = {
        {"ok", HX711_OK},           {"alive", HX711_OK},      {"absent", HX711_ABSENT},
        {"dead", HX711_ABSENT},     {"high", HX711_ABSENT},   {"stuck_low", HX711_STUCK_LOW},
        {"low", HX711_STUCK_LOW},
    };
    for (unsigned i = 0; i < sizeof(alias) / sizeof(alias[0]); i++)
        if (!strcasecmp(s, alias[i].name)) {
            *out = alias[i].mode;
            return 0;
        }
    return -1;
}
