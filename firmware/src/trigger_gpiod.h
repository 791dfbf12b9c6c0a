/* trigger_gpiod.h - thin libgpiod v1 shim: request the board's lines for
 * both-edge events with their bias, read events and feed them to the
 * trigger state machine. Active-low is applied by the state machine (the
 * press edge), not requested from the kernel, so edges arrive as on the wire. */
#ifndef HD_TRIGGER_GPIOD_H
#define HD_TRIGGER_GPIOD_H

#include "hd_defs.h"
#include "trigger.h"

#include <gpiod.h>

struct hd_gpio {
    struct gpiod_chip *chip;
    unsigned count;
    struct gpiod_line *lines[HD_MAX_LINES];
    unsigned offsets[HD_MAX_LINES];
    int fds[HD_MAX_LINES];
    uint64_t read_errors;
};

/* Open the board's [gpio] chip and request every [line N]. One-line error
 * naming the chip, the line and the board file. Returns 0 or -errno. */
int hd_gpio_open(struct hd_gpio *g, const struct hd_board *b, char err[HD_ERR_MAX]);

/* Read one pending event of line i (its fd polled readable) and run it
 * through the state machine. Returns 1 with *out filled when a touch fires,
 * 0 when the edge was a release or a bounce, -errno on a read error (the
 * line stays requested; the caller logs and goes on). */
int hd_gpio_read(struct hd_gpio *g, unsigned i, struct hd_trigger *t, struct hd_event *out);

void hd_gpio_close(struct hd_gpio *g);

#endif
