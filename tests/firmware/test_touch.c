/* Touch logic against hand-computed cases: the panel -> plate maps, nearest
 * focus and the range limit, two contacts in one frame (one trigger, both
 * foci), a contact moving across a cell border with jitter, tracking id
 * reuse, single-touch panels, SYN_DROPPED followed by the device's state
 * again, and a device that disappears. */
#include "touch.h"

#include <errno.h>
#include <linux/input.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

/* 3 x 3 foci at 0.15, 0.35, 0.55 m (x and y), ids 100 + index, index = 3 row + column. */
static const double foci_xy[18] = {0.15, 0.15, 0.35, 0.15, 0.55, 0.15, 0.15, 0.35, 0.35,
                                   0.35, 0.55, 0.35, 0.15, 0.55, 0.35, 0.55, 0.55, 0.55};
static const uint32_t foci_id[9] = {100, 101, 102, 103, 104, 105, 106, 107, 108};

static struct hd_touch *make(double max_distance_m, bool multitouch)
{
    /* Panel units of 0.1 mm on a 0.7 m plate: 0..7000 -> 0..0.7 m. */
    static struct hd_touch t;
    struct hd_touch_map map;
    const double area[4] = {0, 0, 0.7, 0.7};
    assert_int_equal(hd_touch_map_from_area(0, 7000, 0, 7000, area, &map), 0);
    assert_int_equal(hd_touch_init(&t, &map, max_distance_m, 0.005, multitouch, 9, foci_id, foci_xy), 0);
    return &t;
}

static int ev(struct hd_touch *t, uint16_t type, uint16_t code, int32_t value, struct hd_event *out)
{
    return hd_touch_event(t, type, code, value, 1000, out);
}

static void mt_xy(struct hd_touch *t, int32_t slot, int32_t x, int32_t y)
{
    struct hd_event out;
    assert_int_equal(ev(t, EV_ABS, ABS_MT_SLOT, slot, &out), 0);
    assert_int_equal(ev(t, EV_ABS, ABS_MT_POSITION_X, x, &out), 0);
    assert_int_equal(ev(t, EV_ABS, ABS_MT_POSITION_Y, y, &out), 0);
}

static void mt_down(struct hd_touch *t, int32_t slot, int32_t id, int32_t x, int32_t y)
{
    struct hd_event out;
    assert_int_equal(ev(t, EV_ABS, ABS_MT_SLOT, slot, &out), 0);
    assert_int_equal(ev(t, EV_ABS, ABS_MT_TRACKING_ID, id, &out), 0);
    mt_xy(t, slot, x, y);
}

/* SYN_REPORT: returns the foci started (0 terminated), n in *count. */
static int syn(struct hd_touch *t, uint32_t *ids)
{
    struct hd_event out;
    int rc = ev(t, EV_SYN, SYN_REPORT, 0, &out);
    if (rc == 1) {
        assert_int_equal(out.frame, -1);
        assert_int_equal(out.t_ns, 1000);
        memcpy(ids, out.focus_ids, out.focus_count * sizeof *ids);
        return (int)out.focus_count;
    }
    return 0;
}

static void maps(void **state)
{
    (void)state;
    /* Three corners of a panel mounted mirrored in y: panel (0,0) -> plate
     * (0.010, 0.690), (4000,0) -> (0.690, 0.690), (0,3000) -> (0.010, 0.010):
     * x = 0.010 + 0.68 px / 4000, y = 0.690 - 0.68 py / 3000. */
    const double panel[3][2] = {{0, 0}, {4000, 0}, {0, 3000}};
    const double plate[3][2] = {{0.010, 0.690}, {0.690, 0.690}, {0.010, 0.010}};
    struct hd_touch_map m;
    assert_int_equal(hd_touch_map_from_points(&panel[0][0], &plate[0][0], &m), 0);
    double x, y;
    hd_touch_map_apply(&m, 2000, 1500, &x, &y); /* the centre */
    assert_true(fabs(x - 0.35) < 1e-12 && fabs(y - 0.35) < 1e-12);
    hd_touch_map_apply(&m, 4000, 3000, &x, &y); /* the fourth corner, not among the three */
    assert_true(fabs(x - 0.69) < 1e-12 && fabs(y - 0.01) < 1e-12);
    hd_touch_map_apply(&m, 1000, 600, &x, &y); /* 0.010 + 0.17, 0.690 - 0.136 */
    assert_true(fabs(x - 0.18) < 1e-12 && fabs(y - 0.554) < 1e-12);
    /* A panel rotated by 90 degrees: panel x runs along plate y. */
    const double rot_plate[3][2] = {{0.0, 0.0}, {0.0, 0.4}, {0.3, 0.0}};
    assert_int_equal(hd_touch_map_from_points(&panel[0][0], &rot_plate[0][0], &m), 0);
    hd_touch_map_apply(&m, 1000, 1500, &x, &y); /* y = 0.4 * 1000/4000, x = 0.3 * 1500/3000 */
    assert_true(fabs(x - 0.15) < 1e-12 && fabs(y - 0.1) < 1e-12);
    /* Collinear points cannot fix a map. */
    const double line[3][2] = {{0, 0}, {1000, 1000}, {3000, 3000}};
    assert_int_equal(hd_touch_map_from_points(&line[0][0], &plate[0][0], &m), -EINVAL);
    /* Area: panel 0..1000 x 0..500 onto [0.1, 0.6] x [0.2, 0.7]. */
    const double area[4] = {0.1, 0.2, 0.6, 0.7};
    assert_int_equal(hd_touch_map_from_area(0, 1000, 0, 500, area, &m), 0);
    hd_touch_map_apply(&m, 500, 250, &x, &y);
    assert_true(fabs(x - 0.35) < 1e-12 && fabs(y - 0.45) < 1e-12);
    assert_int_equal(hd_touch_map_from_area(5, 5, 0, 500, area, &m), -EINVAL);
    /* Finite points whose map is not (found by the board fuzzer: a plate
     * 1e308 apart made a coefficient -inf, and no touch ever played). */
    const double far_panel[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    const double far_plate[3][2] = {{1e308, 0}, {-1e308, 0}, {0, 0}};
    assert_int_equal(hd_touch_map_from_points(&far_panel[0][0], &far_plate[0][0], &m), -EINVAL);
    const double far_area[4] = {-1e308, 0, 1e308, 1};
    assert_int_equal(hd_touch_map_from_area(0, 1000, 0, 500, far_area, &m), -EINVAL);
}

static void nearest_and_range(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    double d;
    assert_int_equal(hd_touch_nearest(t, 0.36, 0.16, &d), 1); /* focus (0.35, 0.15) */
    assert_true(fabs(d - 0.01 * sqrt(2.0)) < 1e-12);
    assert_int_equal(hd_touch_nearest(t, 0.54, 0.57, &d), 8);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    /* 0.04 m from focus 104 (0.35, 0.35): inside 0.05. */
    mt_down(t, 0, 1, 3500, 3900);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 104);
    /* 0.06 m from the nearest focus (0.15, 0.15): outside, nothing. */
    mt_down(t, 1, 2, 1500, 2100);
    assert_int_equal(syn(t, ids), 0);
    assert_int_equal(t->out_of_range, 1);
    /* It slides to 0.045 m from that focus: now it plays. */
    mt_xy(t, 1, 1500, 1950);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    assert_int_equal(hd_touch_contacts(t), 2);
}

static void two_slots_one_trigger(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    mt_down(t, 0, 10, 1500, 1500); /* focus 100 */
    mt_down(t, 1, 11, 5500, 3500); /* focus 105 */
    assert_int_equal(syn(t, ids), 2);
    assert_int_equal(ids[0], 100);
    assert_int_equal(ids[1], 105);
    /* Two contacts on the same focus in one frame: that focus once. */
    mt_down(t, 2, 12, 3500, 5500);
    mt_down(t, 3, 13, 3550, 5480);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 107);
    /* Nothing moves: nothing plays. */
    assert_int_equal(syn(t, ids), 0);
}

static void moving_across_a_border_with_jitter(void **state)
{
    (void)state;
    /* Foci 100 (0.15, 0.15) and 101 (0.35, 0.15); the cell border is x = 0.25.
     * Along y = 0.15, |p - 100| - |p - 101| = 2 (x - 0.25): the contact
     * switches once x - 0.25 > hysteresis / 2 = 2.5 mm, back once 0.25 - x > 2.5 mm. */
    struct hd_touch *t = make(0.15, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    mt_down(t, 0, 3, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    static const int32_t jitter[] = {2480, 2520, 2490, 2515, 2524, 2476};
    for (size_t i = 0; i < sizeof jitter / sizeof jitter[0]; i++) {
        mt_xy(t, 0, jitter[i], 1500);
        if (syn(t, ids))
            fail_msg("jitter at x = %d re-fired", jitter[i]);
    }
    mt_xy(t, 0, 2526, 1500); /* 2.6 mm past the border */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 101);
    static const int32_t back[] = {2540, 2490, 2476, 2510};
    for (size_t i = 0; i < sizeof back / sizeof back[0]; i++) {
        mt_xy(t, 0, back[i], 1500);
        if (syn(t, ids))
            fail_msg("jitter at x = %d re-fired", back[i]);
    }
    mt_xy(t, 0, 2400, 1500); /* well back in 100's cell */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    assert_int_equal(t->refires, 2);
}

static void leaving_the_range_and_coming_back(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    mt_down(t, 0, 3, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    mt_xy(t, 0, 1500, 2030); /* 0.053 m: beyond 0.05 but within 0.05 + 0.005: still held */
    assert_int_equal(syn(t, ids), 0);
    mt_xy(t, 0, 1500, 1980); /* back inside: held all along, no re-fire */
    assert_int_equal(syn(t, ids), 0);
    mt_xy(t, 0, 1500, 2060); /* 0.056 m: let go */
    assert_int_equal(syn(t, ids), 0);
    mt_xy(t, 0, 1500, 1990); /* 0.049 m: enters again and plays */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
}

static void tracking_id_reuse(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    struct hd_event out;
    mt_down(t, 0, 5, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    /* Lifted, then the same slot and the same tracking id again: a new touch. */
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, -1, &out);
    assert_int_equal(syn(t, ids), 0);
    assert_int_equal(hd_touch_contacts(t), 0);
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, 5, &out); /* position unchanged: the kernel sends none */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    /* A new id in the slot without a release between (a missed frame): new touch. */
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, 6, &out);
    assert_int_equal(syn(t, ids), 1);
    /* The same id repeated within a contact: nothing. */
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, 6, &out);
    assert_int_equal(syn(t, ids), 0);
    /* Slots beyond what is tracked are ignored, not written out of bounds. */
    mt_down(t, (int32_t)HD_TOUCH_SLOTS, 7, 3500, 3500);
    assert_int_equal(syn(t, ids), 0);
    assert_true(t->ignored_slots >= 1);
}

static void single_touch_panel(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, false);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    struct hd_event out;
    ev(t, EV_KEY, BTN_TOUCH, 1, &out);
    ev(t, EV_ABS, ABS_X, 5500, &out);
    ev(t, EV_ABS, ABS_Y, 5500, &out);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 108);
    ev(t, EV_ABS, ABS_X, 5520, &out); /* drag a little */
    assert_int_equal(syn(t, ids), 0);
    ev(t, EV_KEY, BTN_TOUCH, 0, &out);
    assert_int_equal(syn(t, ids), 0);
    ev(t, EV_KEY, BTN_TOUCH, 1, &out); /* tap again at the same place */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 108);
    /* MT events on a single-touch panel mean nothing. */
    mt_down(t, 1, 9, 1500, 1500);
    assert_int_equal(syn(t, ids), 0);
    /* And on an MT panel the kernel's single-touch emulation is ignored. */
    t = make(0.05, true);
    ev(t, EV_KEY, BTN_TOUCH, 1, &out);
    ev(t, EV_ABS, ABS_X, 5500, &out);
    ev(t, EV_ABS, ABS_Y, 5500, &out);
    assert_int_equal(syn(t, ids), 0);
}

static void syn_dropped_resync(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    struct hd_event out;
    mt_down(t, 0, 5, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    /* A frame in progress (slot 0 lifting, slot 1 down on 101) is cut by
     * SYN_DROPPED: none of it counts. */
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, -1, &out);
    mt_down(t, 1, 9, 3500, 1500);
    assert_int_equal(ev(t, EV_SYN, SYN_DROPPED, 0, &out), 0);
    assert_int_equal(t->dropped_frames, 1);
    /* libevdev's sync: slot 0 unchanged (nothing sent), slot 1 now down on
     * 104 after the drop, then SYN_REPORT. Only 104 plays. */
    mt_down(t, 1, 9, 3500, 3500);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 104);
    assert_int_equal(hd_touch_contacts(t), 2); /* contact 5 never lifted */
    /* During a second drop contact 5 lifted and a new one (id 6) came down at
     * the same place: the sync says slot 0 has id 6: it plays. Contact 9 is
     * still there: quiet. */
    mt_xy(t, 1, 3600, 3500);
    assert_int_equal(ev(t, EV_SYN, SYN_DROPPED, 0, &out), 0);
    ev(t, EV_ABS, ABS_MT_SLOT, 0, &out);
    ev(t, EV_ABS, ABS_MT_TRACKING_ID, 6, &out);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    assert_int_equal(hd_touch_contacts(t), 2);
}

static void device_lost(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    mt_down(t, 0, 5, 1500, 1500);
    mt_down(t, 1, 6, 3500, 3500);
    assert_int_equal(syn(t, ids), 2);
    hd_touch_lost(t);
    assert_int_equal(hd_touch_contacts(t), 0);
    /* The device comes back and reports the finger still there with the same
     * tracking id: after a loss it is a new touch. */
    mt_down(t, 0, 5, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
}

static void reloaded_foci(void **state)
{
    (void)state;
    struct hd_touch *t = make(0.05, true);
    uint32_t ids[HD_MAX_EVENT_FOCI];
    mt_down(t, 0, 5, 1500, 1500);
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 100);
    /* A new table: two foci, one of them where the finger rests, renumbered. */
    const uint32_t new_id[2] = {7, 8};
    const double new_xy[4] = {0.16, 0.15, 0.60, 0.60};
    assert_int_equal(hd_touch_set_foci(t, 2, new_id, new_xy), 0);
    mt_xy(t, 0, 1505, 1500); /* the resting finger's next frame: the new table's focus */
    assert_int_equal(syn(t, ids), 1);
    assert_int_equal(ids[0], 7);
    mt_down(t, 1, 6, 3500, 3500); /* where focus 104 was: 0.28 m from the nearest focus now */
    assert_int_equal(syn(t, ids), 0);
    static uint32_t many_id[HD_TOUCH_MAX_FOCI + 1];
    static double many_xy[2 * (HD_TOUCH_MAX_FOCI + 1)];
    assert_int_equal(hd_touch_set_foci(t, HD_TOUCH_MAX_FOCI + 1, many_id, many_xy), -E2BIG);
    assert_int_equal(t->focus_count, 2); /* kept */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(maps),
        cmocka_unit_test(nearest_and_range),
        cmocka_unit_test(two_slots_one_trigger),
        cmocka_unit_test(moving_across_a_border_with_jitter),
        cmocka_unit_test(leaving_the_range_and_coming_back),
        cmocka_unit_test(tracking_id_reuse),
        cmocka_unit_test(single_touch_panel),
        cmocka_unit_test(syn_dropped_resync),
        cmocka_unit_test(device_lost),
        cmocka_unit_test(reloaded_foci),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
