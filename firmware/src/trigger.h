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
#include "event.h"
#include "hd_defs.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

struct hd_trigger_line_state {
    unsigned offset;
    bool active_low;
    bool locked; /* a window is open (locked_until_ns valid) */
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

/* When a GPIO line is given up. A failed event read is usually a glitch
 * (logged, the line stays); HD_LINE_MAX_READ_ERRORS failures in a row are
 * not, and polling on would spin the trigger thread: the line is disabled,
 * as it is at once when its event fd reports an error. Any good read resets
 * the count. Other lines are never affected. */
#define HD_LINE_MAX_READ_ERRORS 100u

enum hd_line_verdict { HD_LINE_OK = 0, HD_LINE_GLITCH, HD_LINE_DISABLED };

struct hd_line_health {
    unsigned read_errors[HD_MAX_LINES]; /* failures in a row */
    bool dead[HD_MAX_LINES];
};

/* Record the outcome of reading line i: read_rc >= 0 or -ENOENT (an edge of a
 * line the board does not name: the read itself worked) is good, any other
 * negative value a failed read. Returns the verdict (HD_LINE_DISABLED from
 * the failure that disables the line on). */
enum hd_line_verdict hd_line_health_read(struct hd_line_health *h, unsigned i, int read_rc);
/* The line's event fd reported POLLERR/POLLNVAL: disabled at once. */
enum hd_line_verdict hd_line_health_fd_error(struct hd_line_health *h, unsigned i);

/* Bytes per host trigger or script line, newline excluded. */
#define HD_TRIGGER_LINE_MAX 510u

/* Parse one host trigger line (no trailing newline needed). Returns 1 with
 * *out filled, 0 for a blank or comment line, -EINVAL with a message in err. */
int hd_host_parse(const char *line, struct hd_event *out, char *err, unsigned err_size);
/* The same for a line of `len` bytes as read (line[len] must be '\0'): a NUL
 * inside it makes the line invalid, where a C string would end at the NUL
 * and play what stood before it ("focus 1\0garbage"). */
int hd_host_parse_line(const char *line, size_t len, struct hd_event *out, char *err, unsigned err_size);

#endif
