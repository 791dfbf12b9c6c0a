/* haptic_table_summary.c - the human summary of a validated table, printed
 * by `calibgen inspect` and `hapticd --check`. The reader has refused any
 * text that is not UTF-8 or holds control characters, so the provenance is
 * printed as stored. */
#include "haptic_table_internal.h"

#include <math.h>

static const char *or_unknown(const char *s) { return s[0] ? s : "(unknown)"; }

int haptic_table_print_summary(const haptic_table *t, const char *path, FILE *out)
{
    if (!t || !t->data || !out)
        return HAPTIC_TABLE_EINVAL;
    haptic_provenance p;
    haptic_table_provenance(t, &p);
    double seconds = (double)t->samples_per_signal / t->sample_rate_hz;
    fprintf(out, "table        %s (%zu bytes, format 1.%u, CRC-32 0x%08lx ok)\n", path ? path : "-", t->size,
            (unsigned)t->format_minor, (unsigned long)t->crc32);
    fprintf(out, "scene        %s (hash %s)\n", or_unknown(p.scene_name), or_unknown(p.scene_hash));
    fprintf(out, "written by   %s on %s\n", or_unknown(p.tool_version), or_unknown(p.created_utc));
    fprintf(out, "signals      %lu foci x %u channels x %lu samples S16LE at %lu Hz (%.1f ms each)\n",
            (unsigned long)t->focus_count, (unsigned)t->channel_count, (unsigned long)t->samples_per_signal,
            (unsigned long)t->sample_rate_hz, 1e3 * seconds);
    const double force = haptic_table_force_full_scale_n(t);
    if (isnan(force))
        fprintf(out, "drive        unknown (no playback section: force per count, drive kind and lead times "
                     "are not in this table)\n");
    else
        fprintf(out, "drive        %s, full scale (32767) = %.6g N, %.6g N per count\n",
                haptic_drive_kind_name(haptic_table_drive_kind(t)), force, force / 32767.0);
    haptic_panel panel;
    if (haptic_table_panel(t, &panel) == 0)
        fprintf(out,
                "panel        calibrated at %.1f C, dE/E/dT %+.3g %%/K (hapticd's [panel] plays it at the panel's "
                "temperature)\n",
                panel.temperature_c, 100 * panel.youngs_per_k);
    else
        fprintf(out, "panel        unknown (no panel section: no temperature compensation from this table)\n");
    const double threshold = haptic_table_range_threshold_m(t);
    if (isnan(threshold))
        fprintf(out, "range        unknown (no range section: hapticd plays any level unclamped)\n");
    else
        fprintf(out,
                "range        threshold %.3g um over %s; per focus 'safe': the gains it passes at (dB, 0 = as "
                "stored)\n",
                1e6 * threshold,
                haptic_table_range_scope(t) == HAPTIC_RANGE_WHOLE_AREA ? "the whole active area (scope 1)"
                                                                       : "the other foci only (scope 2)");
    for (uint32_t c = 0; c < t->channel_count; c++) {
        double x, y;
        haptic_table_channel_position(t, c, &x, &y);
        fprintf(out, "exciter %-4lu (%8.1f, %8.1f) mm\n", (unsigned long)c, 1e3 * x, 1e3 * y);
    }
    double lead_min = INFINITY, lead_max = -INFINITY;
    for (uint32_t f = 0; f < t->focus_count; f++) {
        haptic_focus_info fi;
        haptic_table_focus(t, f, &fi);
        double rms = sqrt(fi.energy / ((double)t->samples_per_signal * t->channel_count)) / 32767.0;
        char lead[32] = "lead ?";
        if (!isnan(fi.lead_time_s)) {
            snprintf(lead, sizeof lead, "lead %.1f ms", 1e3 * fi.lead_time_s);
            lead_min = fmin(lead_min, fi.lead_time_s);
            lead_max = fmax(lead_max, fi.lead_time_s);
        }
        char safe[64] = "";
        haptic_gain_range r;
        if (haptic_table_gain_range(t, f, &r) == 0) {
            if (!(r.lo < r.hi))
                snprintf(safe, sizeof safe, "  safe none: fails at every gain");
            else if (isinf(r.hi))
                snprintf(safe, sizeof safe, "  safe %+.1f dB..unbounded", 20 * log10(r.lo));
            else
                snprintf(safe, sizeof safe, "  safe %+.1f..%+.1f dB", 20 * log10(r.lo), 20 * log10(r.hi));
        }
        fprintf(out, "focus id %-4lu (%8.1f, %8.1f) mm  as stored -> %.3g um  rms %.3f FS  %s%s\n",
                (unsigned long)fi.id, 1e3 * fi.x_m, 1e3 * fi.y_m, 1e6 * fi.scale_m, rms, lead, safe);
    }
    if (lead_min <= lead_max)
        fprintf(out,
                "lead time    %.1f..%.1f ms from playback start to the focal peak (add the input and audio "
                "latency for touch to focus)\n",
                1e3 * lead_min, 1e3 * lead_max);
    return 0;
}
