/* script.h - scripted triggers for the unpaced run (--script): one host
 * command per line, each with 'at FRAME', frames never decreasing. The whole
 * script is read and checked before the device is opened, so a bad line
 * leaves nothing half-written. */
#ifndef HD_SCRIPT_H
#define HD_SCRIPT_H

#include "event.h"
#include "hd_defs.h"

#include <stddef.h>
#include <stdio.h>

struct hd_script {
    struct hd_event *events; /* in file order, frame non-decreasing */
    size_t count;
};

/* Read a script from f; `name` names it in messages. Returns 0, or -EINVAL /
 * -ENOMEM with "NAME:LINE: what is wrong" in err and *s empty. */
int hd_script_read(FILE *f, const char *name, struct hd_script *s, char err[HD_ERR_MAX]);

/* Same from a file ("-": stdin). */
int hd_script_load(const char *path, struct hd_script *s, char err[HD_ERR_MAX]);

void hd_script_free(struct hd_script *s);

#endif
