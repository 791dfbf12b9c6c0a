/* Shared body of the fuzz harnesses: a table the reader accepts must be
 * fully usable through every accessor without touching memory outside it. */
#define _POSIX_C_SOURCE 200809L /* open_memstream */
#include <haptic_table.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void exercise_table(const uint8_t *data, size_t size)
{
    uint8_t *copy = malloc(size ? size : 1); /* exact size: ASan sees any overread */
    memcpy(copy, data, size);
    haptic_table t;
    haptic_table_error err;
    if (haptic_table_validate(copy, size, &t, &err) == 0) {
        volatile double sink = 0;
        for (uint32_t f = 0; f < t.focus_count; f++) {
            haptic_focus_info fi;
            if (haptic_table_focus(&t, f, &fi) != 0 || !(fi.energy > 0))
                abort();
            /* 1.1 facts: known together or not at all, and in their documented ranges. */
            bool known = t.playback_offset != 0;
            if (known != !isnan(fi.lead_time_s) || known != !isnan(haptic_table_force_full_scale_n(&t)) ||
                known != (haptic_table_drive_kind(&t) != HAPTIC_DRIVE_UNKNOWN))
                abort();
            if (known && !(fi.lead_time_s >= 0 && haptic_table_force_full_scale_n(&t) > 0))
                abort();
            /* 1.3 safe range: known with its threshold, in its documented ranges. */
            haptic_gain_range r;
            const bool ranged = haptic_table_gain_range(&t, f, &r) == 0;
            if (ranged != (t.range_offset != 0) || ranged != !isnan(haptic_table_range_threshold_m(&t)))
                abort();
            if (ranged &&
                !(r.lo > 0 && r.lo <= HAPTIC_TABLE_RANGE_MAX_GAIN && r.hi > 0 &&
                  (r.hi <= HAPTIC_TABLE_RANGE_MAX_GAIN || r.hi == INFINITY) && haptic_table_range_threshold_m(&t) > 0 &&
                  haptic_table_range_scope(&t) >= 1 && haptic_table_range_scope(&t) <= 2))
                abort();
            const int16_t *s = haptic_table_signal(&t, f);
            sink += s[0] + s[(size_t)t.samples_per_signal * t.channel_count - 1];
            for (uint32_t g = 0; g < t.focus_count; g++)
                if (!isfinite(haptic_table_gram(&t, f, g)))
                    abort();
        }
        /* The summary of an accepted table is printable text: no control
         * bytes but newlines (the reader refused anything else). */
        char *text = NULL;
        size_t len = 0;
        FILE *mem = open_memstream(&text, &len);
        haptic_table_print_summary(&t, "fuzz", mem);
        fclose(mem);
        for (size_t i = 0; i < len; i++)
            if (((unsigned char)text[i] < 0x20 && text[i] != '\n') || text[i] == 0x7f)
                abort();
        free(text);
        (void)sink;
    } else if (err.message[0] == '\0' || strchr(err.message, '\n')) {
        abort(); /* every refusal carries a one-line message */
    }
    free(copy);
}
