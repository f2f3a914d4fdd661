/*
 * reply.c - buffered single-line JSON writer (see reply.h).
 */
#include "reply.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void reply_init(reply_t *r, int fd)
{
    memset(r, 0, sizeof(*r));
    r->fd = fd;
}

void reply_free(reply_t *r)
{
    free(r->buf);
    r->buf = NULL;
    r->len = r->cap = r->off = 0;
}

static void put(reply_t *r, const char *s, size_t n)
{
    if (r->len + n + 1 > r->cap) {
        /* Compact first: the consumed head is dead weight. */
        if (r->off) {
            memmove(r->buf, r->buf + r->off, r->len - r->off);
            r->len -= r->off;
            r->off = 0;
        }
        size_t cap = r->cap ? r->cap : 4096;
        while (r->len + n + 1 > cap)
            cap *= 2;
        char *nb = realloc(r->buf, cap);
        if (!nb) {
            fprintf(stderr, "fingertip-sim: out of memory for replies\n");
            exit(3);
        }
        r->buf = nb;
        r->cap = cap;
    }
    memcpy(r->buf + r->len, s, n);
    r->len += n;
}

static void putf(reply_t *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void putf(reply_t *r, const char *fmt, ...)
{
    char tmp[128];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof(tmp), fmt, ap);
    va_end(ap);
    if (n > 0)
        put(r, tmp, (size_t)n < sizeof(tmp) ? (size_t)n : sizeof(tmp) - 1);
}

bool reply_pending(const reply_t *r)
{
    return r->len > r->off && !r->broken;
}

void reply_flush(reply_t *r, bool block)
{
    while (reply_pending(r)) {
        struct pollfd p = {.fd = r->fd, .events = POLLOUT};
        int pr = poll(&p, 1, block ? 1000 : 0);
        if (pr == 0) {
            if (block)
                continue;
            return;
        }
        if (pr < 0) {
            if (errno == EINTR)
                continue;
            r->broken = true;
            return;
        }
        if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) {
            r->broken = true;
            return;
        }
        /* POLLOUT on a pipe guarantees room for PIPE_BUF bytes: never blocks. */
        size_t n = r->len - r->off;
        if (n > 4096)
            n = 4096;
        ssize_t w = write(r->fd, r->buf + r->off, n);
        if (w < 0) {
            if (errno == EINTR || errno == EAGAIN)
                continue;
            r->broken = true;
            return;
        }
        r->off += (size_t)w;
    }
    if (r->off == r->len)
        r->off = r->len = 0;
}

/* --- JSON builder --- */

static void sep(reply_t *r)
{
    if (r->depth == 0)
        return;
    if (!r->first[r->depth - 1])
        put(r, ",", 1);
    r->first[r->depth - 1] = false;
}

static void push(reply_t *r, char c)
{
    put(r, &c, 1);
    if (r->depth < REPLY_MAX_DEPTH) {
        r->first[r->depth] = true;
        r->close[r->depth] = c == '{' ? '}' : ']';
    }
    r->depth++;
}

static void escaped(reply_t *r, const char *s)
{
    put(r, "\"", 1);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            char e[2] = {'\\', (char)c};
            put(r, e, 2);
        } else if (c < 0x20) {
            putf(r, "\\u%04x", c);
        } else {
            put(r, (const char *)&c, 1);
        }
    }
    put(r, "\"", 1);
}

static void key(reply_t *r, const char *k)
{
    sep(r);
    if (k) {
        escaped(r, k);
        put(r, ":", 1);
    }
}

void jobj(reply_t *r)
{
    r->depth = 0;
    push(r, '{');
}

void jobj_key(reply_t *r, const char *k)
{
    key(r, k);
    push(r, '{');
}

void jarr_key(reply_t *r, const char *k)
{
    key(r, k);
    push(r, '[');
}

void jobj_elem(reply_t *r)
{
    key(r, NULL);
    push(r, '{');
}

void jend(reply_t *r)
{
    if (r->depth <= 0)
        return;
    r->depth--;
    put(r, &r->close[r->depth], 1);
    if (r->depth == 0)
        put(r, "\n", 1);
}

void jstr(reply_t *r, const char *k, const char *v)
{
    key(r, k);
    escaped(r, v);
}

void jint(reply_t *r, const char *k, int64_t v)
{
    key(r, k);
    putf(r, "%" PRId64, v);
}

void juint(reply_t *r, const char *k, uint64_t v)
{
    key(r, k);
    putf(r, "%" PRIu64, v);
}

void jnum(reply_t *r, const char *k, double v)
{
    key(r, k);
    if (isfinite(v))
        putf(r, "%.9g", v);
    else
        put(r, "null", 4);
}

void jfix(reply_t *r, const char *k, double v, int decimals)
{
    key(r, k);
    if (isfinite(v))
        putf(r, "%.*f", decimals, v);
    else
        put(r, "null", 4);
}

void jbool(reply_t *r, const char *k, bool v)
{
    key(r, k);
    put(r, v ? "true" : "false", v ? 4 : 5);
}

void jnull(reply_t *r, const char *k)
{
    key(r, k);
    put(r, "null", 4);
}

void jarr_int(reply_t *r, int64_t v)
{
    key(r, NULL);
    putf(r, "%" PRId64, v);
}
