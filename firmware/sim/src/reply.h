/*
 * reply.h - the reply stream: single-line JSON objects on the original stdout.
 *
 * Replies are appended to an unbounded buffer and written without blocking
 * from the run loop, so a client that sends thousands of commands before
 * reading any reply can never deadlock the harness (both pipes full).
 */
#ifndef FINGERTIP_SIM_REPLY_H
#define FINGERTIP_SIM_REPLY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define REPLY_MAX_DEPTH 8

typedef struct reply {
    int fd;
    char *buf;
    size_t len, cap, off;       /* bytes [off, len) are still to be written */
    bool broken;                /* reader went away (EPIPE) */
    int depth;
    bool first[REPLY_MAX_DEPTH];
    char close[REPLY_MAX_DEPTH];   /* bracket that closes each level */
} reply_t;

void reply_init(reply_t *r, int fd);
void reply_free(reply_t *r);
bool reply_pending(const reply_t *r);
/* Write what the fd accepts now; with 'block', everything. */
void reply_flush(reply_t *r, bool block);

/* JSON builder: objects/arrays nest; keys are added with the j*() helpers. */
void jobj(reply_t *r);                  /* top level: starts a line */
void jobj_key(reply_t *r, const char *key);
void jarr_key(reply_t *r, const char *key);
void jobj_elem(reply_t *r);             /* object inside an array */
void jend(reply_t *r);                  /* closes; at top level ends the line */
void jstr(reply_t *r, const char *key, const char *v);
void jint(reply_t *r, const char *key, int64_t v);
void juint(reply_t *r, const char *key, uint64_t v);
void jnum(reply_t *r, const char *key, double v);
/* Fixed-point number, for times in us (cycle-exact at 16 MHz with 4 decimals). */
void jfix(reply_t *r, const char *key, double v, int decimals);
void jbool(reply_t *r, const char *key, bool v);
void jnull(reply_t *r, const char *key);
void jarr_int(reply_t *r, int64_t v);   /* element of the current array */

#endif
