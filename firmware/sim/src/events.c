/*
 * events.c - binary min-heap of scheduled input values.
 */
#include "events.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void events_init(events_t *q)
{
    memset(q, 0, sizeof(*q));
}

void events_free(events_t *q)
{
    free(q->heap);
    memset(q, 0, sizeof(*q));
}

void events_clear(events_t *q)
{
    q->n = 0;
}

static bool before(const event_t *a, const event_t *b)
{
    return a->at != b->at ? a->at < b->at : a->seq < b->seq;
}

static void swap(event_t *a, event_t *b)
{
    event_t t = *a;
    *a = *b;
    *b = t;
}

bool events_push(events_t *q, uint64_t at, int ch, bool input_b, int64_t value)
{
    if (q->n == q->cap) {
        size_t cap = q->cap ? q->cap * 2 : 1024;
        event_t *nh = realloc(q->heap, cap * sizeof(*nh));
        if (!nh) {
            fprintf(stderr, "fingertip-sim: out of memory for events\n");
            exit(3);
        }
        q->heap = nh;
        q->cap = cap;
    }
    size_t i = q->n++;
    q->heap[i] = (event_t){.at = at, .seq = q->next_seq++, .value = value, .ch = (int8_t)ch,
                           .input_b = input_b};
    while (i > 0) {
        size_t parent = (i - 1) / 2;
        if (!before(&q->heap[i], &q->heap[parent]))
            break;
        swap(&q->heap[i], &q->heap[parent]);
        i = parent;
    }
    return i == 0;
}

const event_t *events_peek(const events_t *q)
{
    return q->n ? &q->heap[0] : NULL;
}

bool events_pop(events_t *q, event_t *out)
{
    if (!q->n)
        return false;
    *out = q->heap[0];
    q->heap[0] = q->heap[--q->n];
    size_t i = 0;
    for (;;) {
        size_t l = 2 * i + 1, r = l + 1, m = i;
        if (l < q->n && before(&q->heap[l], &q->heap[m]))
            m = l;
        if (r < q->n && before(&q->heap[r], &q->heap[m]))
            m = r;
        if (m == i)
            break;
        swap(&q->heap[i], &q->heap[m]);
        i = m;
    }
    return true;
}
