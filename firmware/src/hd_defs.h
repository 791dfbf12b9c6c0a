/* hd_defs.h - sizes every hapticd module shares: error messages, paths and
 * the fixed capacities that keep the real-time path free of allocation. */
#ifndef HD_DEFS_H
#define HD_DEFS_H

#define HD_MAX_CHANNELS 32u   /* ALSA channels (= HAPTIC_TABLE_MAX_CHANNELS) */
#define HD_MAX_LINES 32u      /* GPIO trigger lines per board */
#define HD_MAX_EVENT_FOCI 16u /* foci one trigger may select */
#define HD_MAX_VOICE_FOCI 32u /* foci one voice may play (the union of the triggers merged into it) */
#define HD_PATH_MAX 512u
#define HD_ERR_MAX 1400u /* one-line error messages, a path or two included */

#endif
