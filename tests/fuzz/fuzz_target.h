/* Shared body of the fuzz harnesses: a table the reader accepts must be
 * fully usable through every accessor without touching memory outside it. */
#include <haptic_table.h>
#include <math.h>
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
            const int16_t *s = haptic_table_signal(&t, f);
            sink += s[0] + s[(size_t)t.samples_per_signal * t.channel_count - 1];
            for (uint32_t g = 0; g < t.focus_count; g++)
                if (!isfinite(haptic_table_gram(&t, f, g)))
                    abort();
        }
        FILE *null = fopen("/dev/null", "w");
        haptic_table_print_summary(&t, "fuzz", null);
        fclose(null);
        (void)sink;
    } else if (err.message[0] == '\0' || strchr(err.message, '\n')) {
        abort(); /* every refusal carries a one-line message */
    }
    free(copy);
}
