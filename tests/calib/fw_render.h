/* fw_render.h - hapticd's own player, callable from the C++ suites: the
 * voice hapticd plays for the given focus ids of a table file, rendered
 * period by period to S16 frames (identity channel map, gain limit 1, no
 * exciter ratings). Returns 0, or -1 with a message on stderr. */
#ifndef FW_RENDER_H
#define FW_RENDER_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

int fw_render_s16(const char *table_path, const uint32_t *ids, unsigned count, int16_t *out, uint32_t frames);

#ifdef __cplusplus
}
#endif

#endif
