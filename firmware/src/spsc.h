/* spsc.h - lock-free single-producer single-consumer ring of trigger events
 * (C11 atomics). The trigger thread pushes; the real-time audio thread peeks
 * and releases what it has started (engine.c).
 * Fixed capacity, no allocation: a full ring drops the new event and counts
 * it, so a trigger storm cannot grow memory or block either side. */
#ifndef HD_SPSC_H
#define HD_SPSC_H

#include "event.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#define HD_RING_SIZE 256u /* power of two */

struct hd_spsc {
    _Alignas(64) _Atomic uint32_t head; /* next slot to pop (consumer writes) */
    _Alignas(64) _Atomic uint32_t tail; /* next slot to push (producer writes) */
    _Atomic uint64_t dropped;
    struct hd_event slots[HD_RING_SIZE];
};

static inline void hd_spsc_init(struct hd_spsc *r)
{
    atomic_init(&r->head, 0);
    atomic_init(&r->tail, 0);
    atomic_init(&r->dropped, 0);
}

/* Producer side. Returns false (and counts a drop) when the ring is full. */
static inline bool hd_spsc_push(struct hd_spsc *r, const struct hd_event *ev)
{
    uint32_t t = atomic_load_explicit(&r->tail, memory_order_relaxed);
    uint32_t h = atomic_load_explicit(&r->head, memory_order_acquire);
    if (t - h == HD_RING_SIZE) {
        atomic_fetch_add_explicit(&r->dropped, 1, memory_order_relaxed);
        return false;
    }
    r->slots[t & (HD_RING_SIZE - 1)] = *ev;
    atomic_store_explicit(&r->tail, t + 1, memory_order_release);
    return true;
}

/* Consumer side: the i-th event not yet released (0 = the oldest), without
 * taking it. Returns false when fewer than i + 1 events wait. */
static inline bool hd_spsc_peek(struct hd_spsc *r, uint32_t i, struct hd_event *ev)
{
    uint32_t h = atomic_load_explicit(&r->head, memory_order_relaxed);
    uint32_t t = atomic_load_explicit(&r->tail, memory_order_acquire);
    if (t - h <= i)
        return false;
    *ev = r->slots[(h + i) & (HD_RING_SIZE - 1)];
    return true;
}

/* Consumer side: the n oldest events (all peeked) leave the ring. The release
 * store publishes whatever the consumer wrote before it (the engine's active
 * voice count) to a thread that then sees the ring empty. */
static inline void hd_spsc_release(struct hd_spsc *r, uint32_t n)
{
    uint32_t h = atomic_load_explicit(&r->head, memory_order_relaxed);
    atomic_store_explicit(&r->head, h + n, memory_order_release);
}

/* Any thread: whether every event pushed so far has been released. Exact
 * for the consumer and for a thread that knows no push is under way (the
 * producer stopped); otherwise a snapshot. */
static inline bool hd_spsc_empty(struct hd_spsc *r)
{
    uint32_t h = atomic_load_explicit(&r->head, memory_order_acquire);
    uint32_t t = atomic_load_explicit(&r->tail, memory_order_acquire);
    return h == t;
}

#endif
