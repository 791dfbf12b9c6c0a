/* touch.c - contacts to focus triggers (pure logic, see touch.h). */
#define _POSIX_C_SOURCE 200809L
#include "touch.h"

#include <errno.h>
#include <linux/input.h>
#include <math.h>
#include <string.h>

int hd_touch_map_from_points(const double *panel, const double *plate, struct hd_touch_map *out)
{
    /* Solve [px py 1] * [a b c]^T = plate_x (and _y) for the three points by
     * Cramer's rule; the determinant is twice the panel triangle's area. */
    const double x1 = panel[0], y1 = panel[1], x2 = panel[2], y2 = panel[3], x3 = panel[4], y3 = panel[5];
    const double det = x1 * (y2 - y3) - y1 * (x2 - x3) + (x2 * y3 - x3 * y2);
    const double span = fmax(fmax(fabs(x2 - x1), fabs(x3 - x1)), fmax(fabs(y2 - y1), fabs(y3 - y1)));
    if (!(fabs(det) > 1e-9 * span * span) || !isfinite(det))
        return -EINVAL;
    for (int k = 0; k < 2; k++) {
        const double v1 = plate[k], v2 = plate[2 + k], v3 = plate[4 + k];
        out->m[3 * k + 0] = (v1 * (y2 - y3) - y1 * (v2 - v3) + (v2 * y3 - v3 * y2)) / det;
        out->m[3 * k + 1] = (x1 * (v2 - v3) - v1 * (x2 - x3) + (x2 * v3 - x3 * v2)) / det;
        out->m[3 * k + 2] = (x1 * (y2 * v3 - y3 * v2) - y1 * (x2 * v3 - x3 * v2) + v1 * (x2 * y3 - x3 * y2)) / det;
    }
    for (int i = 0; i < 6; i++)
        if (!isfinite(out->m[i])) /* finite points, but a map beyond double range (e.g. plate 1e308 apart) */
            return -EINVAL;
    return 0;
}

int hd_touch_map_from_area(int32_t x_min, int32_t x_max, int32_t y_min, int32_t y_max, const double area[4],
                           struct hd_touch_map *out)
{
    if (x_max <= x_min || y_max <= y_min)
        return -EINVAL;
    const double sx = (area[2] - area[0]) / ((double)x_max - x_min), sy = (area[3] - area[1]) / ((double)y_max - y_min);
    *out = (struct hd_touch_map){{sx, 0, area[0] - sx * x_min, 0, sy, area[1] - sy * y_min}};
    for (int i = 0; i < 6; i++)
        if (!isfinite(out->m[i])) /* an area beyond double range (-1e308..1e308) */
            return -EINVAL;
    return 0;
}

void hd_touch_map_apply(const struct hd_touch_map *map, double px, double py, double *x_m, double *y_m)
{
    *x_m = map->m[0] * px + map->m[1] * py + map->m[2];
    *y_m = map->m[3] * px + map->m[4] * py + map->m[5];
}

static void clear_contacts(struct hd_touch_contact *c)
{
    for (unsigned s = 0; s < HD_TOUCH_SLOTS; s++)
        c[s] = (struct hd_touch_contact){.tracking_id = -1, .focus = -1};
}

int hd_touch_set_foci(struct hd_touch *t, uint32_t focus_count, const uint32_t *focus_id, const double *focus_xy_m)
{
    if (focus_count > HD_TOUCH_MAX_FOCI)
        return -E2BIG;
    t->focus_count = focus_count;
    for (uint32_t f = 0; f < focus_count; f++) {
        t->focus_id[f] = focus_id[f];
        t->focus_xy_m[f][0] = focus_xy_m[2 * f];
        t->focus_xy_m[f][1] = focus_xy_m[2 * f + 1];
    }
    for (unsigned s = 0; s < HD_TOUCH_SLOTS; s++)
        t->now[s].focus = t->frame[s].focus = -1;
    return 0;
}

int hd_touch_init(struct hd_touch *t, const struct hd_touch_map *map, double max_distance_m, double hysteresis_m,
                  bool multitouch, uint32_t focus_count, const uint32_t *focus_id, const double *focus_xy_m)
{
    if (focus_count > HD_TOUCH_MAX_FOCI)
        return -E2BIG;
    memset(t, 0, sizeof *t);
    t->map = *map;
    t->max_distance_m = max_distance_m;
    t->hysteresis_m = hysteresis_m;
    t->multitouch = multitouch;
    clear_contacts(t->now);
    clear_contacts(t->frame);
    return hd_touch_set_foci(t, focus_count, focus_id, focus_xy_m);
}

int32_t hd_touch_nearest(const struct hd_touch *t, double x_m, double y_m, double *distance_m)
{
    int32_t best = -1;
    double best_d2 = INFINITY;
    for (uint32_t f = 0; f < t->focus_count; f++) {
        double dx = x_m - t->focus_xy_m[f][0], dy = y_m - t->focus_xy_m[f][1], d2 = dx * dx + dy * dy;
        if (d2 < best_d2) { /* ties: the first focus in table order */
            best_d2 = d2;
            best = (int32_t)f;
        }
    }
    *distance_m = sqrt(best_d2);
    return best;
}

static double distance_to(const struct hd_touch *t, int32_t f, double x_m, double y_m)
{
    return hypot(x_m - t->focus_xy_m[f][0], y_m - t->focus_xy_m[f][1]);
}

/* The contact's focus after this frame; returns the focus it starts, or -1. */
static int32_t settle(struct hd_touch *t, struct hd_touch_contact *c, bool new_contact)
{
    if (c->tracking_id < 0 || !c->seen_xy) {
        if (c->tracking_id < 0)
            c->focus = -1;
        return -1;
    }
    double x, y, dn;
    hd_touch_map_apply(&t->map, c->x, c->y, &x, &y);
    int32_t n = hd_touch_nearest(t, x, y, &dn);
    if (n < 0)
        return -1;
    if (c->focus < 0) {
        if (dn <= t->max_distance_m) {
            c->focus = n;
            t->touches++;
            return n;
        }
        if (new_contact)
            t->out_of_range++;
        return -1;
    }
    double dc = distance_to(t, c->focus, x, y);
    if (dc > t->max_distance_m + t->hysteresis_m) {
        c->focus = -1; /* left the range: coming back plays again */
        return -1;
    }
    if (n != c->focus && dc > dn + t->hysteresis_m) {
        c->focus = n;
        t->refires++;
        return n;
    }
    return -1;
}

static int report(struct hd_touch *t, uint64_t timestamp_ns, struct hd_event *out)
{
    uint32_t ids[HD_MAX_EVENT_FOCI];
    uint32_t n = 0;
    for (unsigned s = 0; s < HD_TOUCH_SLOTS; s++) {
        struct hd_touch_contact *c = &t->now[s];
        bool new_contact = c->tracking_id >= 0 && c->tracking_id != t->frame[s].tracking_id;
        int32_t f = settle(t, c, new_contact);
        if (f < 0)
            continue;
        uint32_t k;
        for (k = 0; k < n && ids[k] != t->focus_id[f]; k++)
            ;
        if (k == n && n < HD_MAX_EVENT_FOCI)
            ids[n++] = t->focus_id[f];
    }
    memcpy(t->frame, t->now, sizeof t->frame);
    if (!n)
        return 0;
    memset(out, 0, sizeof *out);
    out->t_ns = timestamp_ns;
    out->frame = -1;
    out->focus_count = n;
    memcpy(out->focus_ids, ids, n * sizeof *ids);
    return 1;
}

static struct hd_touch_contact *current(struct hd_touch *t)
{
    if (t->slot >= HD_TOUCH_SLOTS)
        return NULL;
    return &t->now[t->slot];
}

static void begin(struct hd_touch_contact *c, int32_t tracking_id)
{
    if (tracking_id < 0) {
        c->tracking_id = -1;
        return;
    }
    if (tracking_id != c->tracking_id) {
        /* A new contact; the slot keeps its last position (protocol B sends
         * only values that changed). */
        c->tracking_id = tracking_id;
        c->focus = -1;
    }
}

int hd_touch_event(struct hd_touch *t, uint16_t type, uint16_t code, int32_t value, uint64_t timestamp_ns,
                   struct hd_event *out)
{
    struct hd_touch_contact *c;
    if (type == EV_SYN) {
        if (code == SYN_REPORT)
            return report(t, timestamp_ns, out);
        if (code == SYN_DROPPED) { /* the frame in progress is incomplete: forget it */
            memcpy(t->now, t->frame, sizeof t->now);
            t->dropped_frames++;
        }
        return 0;
    }
    if (t->multitouch && type == EV_ABS) {
        switch (code) {
        case ABS_MT_SLOT:
            t->slot = value >= 0 && (uint32_t)value < HD_TOUCH_SLOTS ? (uint32_t)value : HD_TOUCH_SLOTS;
            if (t->slot == HD_TOUCH_SLOTS)
                t->ignored_slots++;
            return 0;
        case ABS_MT_TRACKING_ID:
            if ((c = current(t)))
                begin(c, value);
            return 0;
        case ABS_MT_POSITION_X:
        case ABS_MT_POSITION_Y:
            if ((c = current(t))) {
                *(code == ABS_MT_POSITION_X ? &c->x : &c->y) = value;
                c->seen_xy = true;
            }
            return 0;
        default:
            return 0;
        }
    }
    if (!t->multitouch) {
        c = &t->now[0];
        if (type == EV_KEY && code == BTN_TOUCH) {
            /* Each press is a new contact: number them as tracking ids. */
            if (value)
                begin(c, c->tracking_id >= 0 ? c->tracking_id
                                             : (t->single_touch_id = (t->single_touch_id + 1) & 0x7fffffff));
            else
                begin(c, -1);
        } else if (type == EV_ABS && (code == ABS_X || code == ABS_Y)) {
            *(code == ABS_X ? &c->x : &c->y) = value;
            c->seen_xy = true;
        }
    }
    return 0;
}

void hd_touch_lost(struct hd_touch *t)
{
    for (unsigned s = 0; s < HD_TOUCH_SLOTS; s++) {
        t->now[s].tracking_id = t->frame[s].tracking_id = -1;
        t->now[s].focus = t->frame[s].focus = -1;
    }
    t->slot = 0;
}

uint32_t hd_touch_contacts(const struct hd_touch *t)
{
    uint32_t n = 0;
    for (unsigned s = 0; s < HD_TOUCH_SLOTS; s++)
        n += t->frame[s].tracking_id >= 0;
    return n;
}
