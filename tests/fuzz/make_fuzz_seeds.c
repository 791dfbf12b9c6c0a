/* Writes a few valid tables of different shapes as the fuzz seed corpus:
 * format 1.3 with the playback and panel sections, one without the playback
 * section (drive kind unknown), two with the range section (one with a
 * focus that fails at every gain and one without the other sections). A
 * table of the 1.0 writer is in tests/fuzz/regressions/. */
#include <stdio.h>
#include <stdlib.h>

#include "table_fixture.h"

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: make_fuzz_seeds DIR\n");
        return 2;
    }
    const struct {
        uint16_t c;
        uint32_t k, n;
    } shapes[] = {{1, 1, 1}, {2, 2, 16}, {8, 3, 40}, {8, 9, 8}, {32, 2, 4}};
    for (size_t i = 0; i < sizeof shapes / sizeof *shapes; i++) {
        table_fixture fx;
        table_fixture_init(&fx, shapes[i].c, shapes[i].k, shapes[i].n, (uint32_t)i + 1);
        if (i == 1)
            fx.spec.drive_kind = HAPTIC_DRIVE_UNKNOWN;
        if (i == 2 || i == 4) {
            fx.spec.range = &fx.range;
            fx.gain_range[0].lo = 4 * fx.gain_range[0].hi; /* a focus that fails at every gain */
        }
        if (i == 4) {
            fx.spec.drive_kind = HAPTIC_DRIVE_UNKNOWN;
            fx.spec.panel = NULL;
            fx.range.scope = HAPTIC_RANGE_FOCI_ONLY;
        }
        char path[4096];
        snprintf(path, sizeof path, "%s/seed%zu.htab", argv[1], i);
        haptic_table_error err;
        if (haptic_table_write(path, &fx.spec, &err) != 0) {
            fprintf(stderr, "make_fuzz_seeds: %s: %s\n", path, err.message);
            return 1;
        }
        table_fixture_free(&fx);
    }
    return 0;
}
