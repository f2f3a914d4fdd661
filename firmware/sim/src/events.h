/*
 * events.h - input values scheduled at exact simulated times.
 *
 * A min-heap ordered by (time, arrival order): values given for the same
 * instant are applied in the order they were sent. The harness arms a
 * single simavr cycle timer for the earliest one.
 */
#ifndef FINGERTIP_SIM_EVENTS_H
#define FINGERTIP_SIM_EVENTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct event {
    uint64_t at;        /* hcycles */
    uint64_t seq;       /* arrival order, breaks ties */
    int64_t value;
    int8_t ch;
    bool input_b;       /* channel B input instead of A */
} event_t;

typedef struct events {
    event_t *heap;
    size_t n, cap;
    uint64_t next_seq;
} events_t;

void events_init(events_t *q);
void events_free(events_t *q);
void events_clear(events_t *q);
/* Returns true when the new event became the earliest (the timer must move). */
bool events_push(events_t *q, uint64_t at, int ch, bool input_b, int64_t value);
const event_t *events_peek(const events_t *q);
bool events_pop(events_t *q, event_t *out);

#endif
