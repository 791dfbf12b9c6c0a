/* trigger.h - touch trigger logic, independent of where events come from.
 *
 * GPIO lines: libgpiod v1 has no debounce, so a line fires on the first
 * *press* edge (falling for an active-low line, rising otherwise) and is then
 * locked out for lockout_ns measured on the event timestamps. Any edge seen
 * while the line is not locked starts a new lockout window, including a
 * release edge, so the bounce of a release cannot fire either. Edges inside
 * the window are ignored (counted as bounces) and do not extend it.
 *
 * Host triggers (stdin or a FIFO, one command per line):
 *   focus 3            play focus id 3
 *   foci 1,4           play foci 1 and 4 together (one mix)
 *   at 4800 focus 3    scripted mode: start at device frame 4800 (see docs/firmware.md)
 *   # comment / blank  ignored
 */
#ifndef HD_TRIGGER_H
#define HD_TRIGGER_H

#include "board.h"

#include <stdbool.h>
#include <stdint.h>

/* One trigger: the foci (table ids) to play, and when it happened. */
struct hd_event {
    uint64_t t_ns;                 /* CLOCK_MONOTONIC when the daemon saw it (latency stats) */
    int64_t frame;                 /* scripted start frame, or -1 for "as soon as possible" */
    uint32_t focus_count;
    uint32_t focus_ids[HD_MAX_EVENT_FOCI];
};

struct hd_trigger_line_state {
    unsigned offset;
    bool active_low;
    bool locked;                   /* a window is open (locked_until_ns valid) */
    uint64_t locked_until_ns;
    uint32_t focus_count;
    uint32_t focus_ids[HD_MAX_EVENT_FOCI];
};

struct hd_trigger {
    uint64_t lockout_ns;
    unsigned line_count;
    struct hd_trigger_line_state lines[HD_MAX_LINES];
    uint64_t fired, bounces, releases, unknown_lines;
};

enum hd_edge { HD_EDGE_RISING = 1, HD_EDGE_FALLING = 2 };

void hd_trigger_init(struct hd_trigger *t, const struct hd_board *b);

/* Index of the line with this GPIO offset, or -1. */
int hd_trigger_line_index(const struct hd_trigger *t, unsigned offset);

/* Feed one edge. Returns 1 and fills *out when the line fires, 0 when the
 * edge is ignored (release, bounce), -ENOENT for a line the board does not
 * know. timestamp_ns is the event's own timestamp (any monotonic-enough clock). */
int hd_trigger_edge(struct hd_trigger *t, unsigned offset, enum hd_edge edge, uint64_t timestamp_ns,
                    struct hd_event *out);

/* Parse one host trigger line (no trailing newline needed). Returns 1 with
 * *out filled, 0 for a blank or comment line, -EINVAL with a message in err. */
int hd_host_parse(const char *line, struct hd_event *out, char *err, unsigned err_size);

#endif
