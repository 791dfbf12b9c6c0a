/* haptic_table_content.c - what the reader checks once the header, layout
 * and CRC-32 are good: reserved bytes and gaps, records, the playback, panel
 * and range sections, the Gram matrix, provenance text, and the payload
 * against the Gram matrix. The order of the checks (and so which error a
 * table with several faults gets) is the one docs/table-format.md lists. */
#include "haptic_table_internal.h"

#include <math.h>

#define fail haptic_table_fail_

static double gram_at(const uint8_t *b, const haptic_table *t, uint32_t i, uint32_t j)
{
    return rdf64(b + t->gram_offset + ((uint64_t)i * t->focus_count + j) * 8);
}

static int zero_bytes(const uint8_t *b, uint64_t from, uint64_t to, const char *what, haptic_table_error *err)
{
    for (uint64_t k = from; k < to; k++)
        if (b[k] != 0)
            return fail(err, HAPTIC_TABLE_EFIELD, k, "offset %llu (%s): byte 0x%02x, must be 0", (unsigned long long)k,
                        what, b[k]);
    return 0;
}

/* In a file of a minor version this reader knows, nothing is unexplained:
 * unknown optional flags, reserved header bytes and the gaps between sections
 * are zero. A later minor may use them, so they are not checked there. */
static int check_reserved(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    if (t->format_minor > HAPTIC_TABLE_VERSION_MINOR)
        return 0;
    const uint32_t known = (t->format_minor >= 1 ? HAPTIC_TABLE_FLAG_PLAYBACK : 0) |
                           (t->format_minor >= 2 ? HAPTIC_TABLE_FLAG_PANEL : 0) |
                           (t->format_minor >= 3 ? HAPTIC_TABLE_FLAG_RANGE : 0);
    if (t->flags & ~FLAGS_REQUIRED_MASK & ~known)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_FLAGS,
                    "offset %d (flags): optional bits 0x%08lx unknown in version 1.%u", OFF_FLAGS,
                    (unsigned long)(t->flags & ~FLAGS_REQUIRED_MASK & ~known), (unsigned)t->format_minor);
    int rc;
    /* An absent section's offset field is reserved (zero) too. */
    if (!t->playback_offset &&
        (rc = zero_bytes(b, OFF_PLAYBACK_OFFSET, OFF_PLAYBACK_OFFSET + 8, "header reserved", err)))
        return rc;
    if (!t->panel_offset && (rc = zero_bytes(b, OFF_PANEL_OFFSET, OFF_PANEL_OFFSET + 8, "header reserved", err)))
        return rc;
    if (!t->range_offset && (rc = zero_bytes(b, OFF_RANGE_OFFSET, OFF_RANGE_OFFSET + 8, "header reserved", err)))
        return rc;
    if ((rc = zero_bytes(b, OFF_HEADER_RESERVED, HAPTIC_TABLE_HEADER_SIZE, "header reserved", err)))
        return rc;
    /* Sections in file order with their sizes; gaps lie between them. */
    struct {
        uint64_t off, size;
    } s[8] = {
        {t->channels_offset, (uint64_t)t->channel_count * HAPTIC_TABLE_CHANNEL_RECORD_SIZE},
        {t->foci_offset, (uint64_t)t->focus_count * HAPTIC_TABLE_FOCUS_RECORD_SIZE},
        {t->gram_offset, (uint64_t)t->focus_count * t->focus_count * 8},
        {t->provenance_offset, HAPTIC_TABLE_PROVENANCE_SIZE},
        {t->playback_offset, t->playback_offset ? playback_section_size(t->focus_count) : 0},
        {t->panel_offset, t->panel_offset ? HAPTIC_TABLE_PANEL_SIZE : 0},
        {t->range_offset, t->range_offset ? range_section_size(t->focus_count) : 0},
        {t->payload_offset, 0},
    };
    uint64_t end = HAPTIC_TABLE_HEADER_SIZE;
    for (int i = 0; i < 8; i++) {
        if (s[i].off == 0)
            continue; /* an absent section */
        if ((rc = zero_bytes(b, end, s[i].off, "gap between sections", err)))
            return rc;
        end = s[i].off + s[i].size;
    }
    return 0;
}

static int check_channels(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    for (uint32_t c = 0; c < t->channel_count; c++) {
        uint64_t off = t->channels_offset + (uint64_t)c * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
        for (int k = 0; k < 2; k++) {
            double v = rdf64(b + off + 8 * k);
            if (!isfinite(v) || fabs(v) > 1e3)
                return fail(err, HAPTIC_TABLE_EFIELD, off + 8 * k,
                            "offset %llu (channel %lu %s_m): %g is not a finite position within 1 km",
                            (unsigned long long)(off + 8 * k), (unsigned long)c, k ? "y" : "x", v);
        }
    }
    return 0;
}

/* Every u32 is a valid id (0 and 0xFFFFFFFF included: the scene allows them);
 * only a repeat is refused, named at the later focus. */
static int check_foci(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    for (uint32_t f = 0; f < t->focus_count; f++) {
        uint64_t off = t->foci_offset + (uint64_t)f * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
        const uint8_t *r = b + off;
        if (rd32(r + FOC_RESERVED) != 0 || rd64(r + FOC_RESERVED2) != 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_RESERVED, "offset %llu (focus %lu reserved): must be 0",
                        (unsigned long long)(off + FOC_RESERVED), (unsigned long)f);
        static const char *const names[] = {"x_m", "y_m", "scale_m"};
        for (int k = 0; k < 3; k++) {
            double v = rdf64(r + FOC_X + 8 * k);
            bool ok = isfinite(v) && fabs(v) <= 1e3 && (k < 2 || v > 0.0);
            if (!ok)
                return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_X + 8 * k, "offset %llu (focus %lu %s): %g is invalid",
                            (unsigned long long)(off + FOC_X + 8 * k), (unsigned long)f, names[k], v);
        }
        uint32_t id = rd32(r + FOC_ID);
        for (uint32_t g = 0; g < f; g++)
            if (rd32(b + t->foci_offset + (uint64_t)g * HAPTIC_TABLE_FOCUS_RECORD_SIZE + FOC_ID) == id)
                return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_ID, "offset %llu (focus %lu id): %lu repeats focus %lu",
                            (unsigned long long)(off + FOC_ID), (unsigned long)f, (unsigned long)id, (unsigned long)g);
        double energy = rdf64(r + FOC_ENERGY);
        double diag = gram_at(b, t, f, f);
        if (!(energy > 0.0) || !isfinite(energy) || energy != diag)
            return fail(err, HAPTIC_TABLE_EGRAM, off + FOC_ENERGY,
                        "offset %llu (focus %lu energy): %g must be positive and equal Gram[%lu][%lu] = %g",
                        (unsigned long long)(off + FOC_ENERGY), (unsigned long)f, energy, (unsigned long)f,
                        (unsigned long)f, diag);
    }
    return 0;
}

static int check_panel(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    if (!t->panel_offset)
        return 0;
    const uint64_t off = t->panel_offset;
    const double temp = rdf64(b + off + PANEL_TEMPERATURE);
    if (!(temp >= HAPTIC_TABLE_PANEL_MIN_TEMPERATURE_C && temp <= HAPTIC_TABLE_PANEL_MAX_TEMPERATURE_C))
        return fail(err, HAPTIC_TABLE_EFIELD, off + PANEL_TEMPERATURE,
                    "offset %llu (panel temperature_c): %g is outside %g..%g degrees C",
                    (unsigned long long)(off + PANEL_TEMPERATURE), temp, HAPTIC_TABLE_PANEL_MIN_TEMPERATURE_C,
                    HAPTIC_TABLE_PANEL_MAX_TEMPERATURE_C);
    const double k = rdf64(b + off + PANEL_YOUNGS_PER_K);
    if (!(fabs(k) <= HAPTIC_TABLE_PANEL_MAX_YOUNGS_PER_K))
        return fail(err, HAPTIC_TABLE_EFIELD, off + PANEL_YOUNGS_PER_K,
                    "offset %llu (panel youngs_per_k): %g is outside +-%g per K",
                    (unsigned long long)(off + PANEL_YOUNGS_PER_K), k, HAPTIC_TABLE_PANEL_MAX_YOUNGS_PER_K);
    return zero_bytes(b, off + PANEL_RESERVED, off + HAPTIC_TABLE_PANEL_SIZE, "panel reserved", err);
}

/* The safe range of each focus (1.3): a threshold, where the verdict looked,
 * and per focus the gains [lo, hi) over which it passes. lo >= hi is allowed
 * (a focus that fails at every gain is stated, not hidden); hi is +infinity
 * when nothing beyond lambda/2 moves. */
static int check_range(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    if (!t->range_offset)
        return 0;
    const uint64_t off = t->range_offset;
    const double threshold = rdf64(b + off + RANGE_THRESHOLD);
    if (!(isfinite(threshold) && threshold > 0.0 && threshold <= 1e3))
        return fail(err, HAPTIC_TABLE_EFIELD, off + RANGE_THRESHOLD,
                    "offset %llu (range threshold_m): %g is not a displacement in (0, 1000] m",
                    (unsigned long long)(off + RANGE_THRESHOLD), threshold);
    const uint16_t scope = rd16(b + off + RANGE_SCOPE);
    if (scope != HAPTIC_RANGE_WHOLE_AREA && scope != HAPTIC_RANGE_FOCI_ONLY)
        return fail(err, HAPTIC_TABLE_EFIELD, off + RANGE_SCOPE,
                    "offset %llu (range scope): %u, only 1 (whole area) or 2 (foci only) are known",
                    (unsigned long long)(off + RANGE_SCOPE), (unsigned)scope);
    int rc;
    if ((rc = zero_bytes(b, off + RANGE_RESERVED, off + RANGE_GAINS, "range reserved", err)))
        return rc;
    for (uint32_t f = 0; f < t->focus_count; f++) {
        const uint64_t at = off + RANGE_GAINS + (uint64_t)f * 16;
        const double lo = rdf64(b + at), hi = rdf64(b + at + 8);
        if (!(isfinite(lo) && lo > 0.0 && lo <= HAPTIC_TABLE_RANGE_MAX_GAIN))
            return fail(err, HAPTIC_TABLE_EFIELD, at, "offset %llu (focus %lu gain_lo): %g is not a gain in (0, %g]",
                        (unsigned long long)at, (unsigned long)f, lo, HAPTIC_TABLE_RANGE_MAX_GAIN);
        if (!(hi > 0.0 && (hi <= HAPTIC_TABLE_RANGE_MAX_GAIN || hi == INFINITY)))
            return fail(err, HAPTIC_TABLE_EFIELD, at + 8,
                        "offset %llu (focus %lu gain_hi): %g is not a gain in (0, %g] or +inf",
                        (unsigned long long)(at + 8), (unsigned long)f, hi, HAPTIC_TABLE_RANGE_MAX_GAIN);
    }
    return 0;
}

static int check_playback(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    if (!t->playback_offset)
        return 0;
    const uint64_t off = t->playback_offset;
    double force = rdf64(b + off + PLAY_FORCE);
    if (!(isfinite(force) && force > 0.0 && force <= FORCE_FULL_SCALE_MAX_N))
        return fail(err, HAPTIC_TABLE_EFIELD, off + PLAY_FORCE,
                    "offset %llu (force_full_scale_n): %g is not a force in (0, 1e6] N",
                    (unsigned long long)(off + PLAY_FORCE), force);
    uint16_t kind = rd16(b + off + PLAY_DRIVE_KIND);
    if (kind < HAPTIC_DRIVE_FORCE || kind > HAPTIC_DRIVE_EXCITER_PRECOMPENSATED)
        return fail(err, HAPTIC_TABLE_EFIELD, off + PLAY_DRIVE_KIND, "offset %llu (drive_kind): %u is outside 1..3",
                    (unsigned long long)(off + PLAY_DRIVE_KIND), (unsigned)kind);
    int rc;
    if ((rc = zero_bytes(b, off + PLAY_RESERVED, off + PLAY_LEAD_TIMES, "playback reserved", err)))
        return rc;
    const double last_s = (double)t->samples_per_signal / (double)t->sample_rate_hz + LEAD_TIME_SLACK_S;
    for (uint32_t f = 0; f < t->focus_count; f++) {
        uint64_t at = off + PLAY_LEAD_TIMES + (uint64_t)f * 8;
        double lead = rdf64(b + at);
        if (!(isfinite(lead) && lead >= 0.0 && lead <= last_s))
            return fail(err, HAPTIC_TABLE_EFIELD, at, "offset %llu (focus %lu lead_time_s): %g is outside 0..%g s",
                        (unsigned long long)at, (unsigned long)f, lead, last_s);
    }
    return 0;
}

/* Lower triangle, row by row: the first failing gram[i][j] (i > j) is named.
 * The diagonal was checked with the focus energies. */
static int check_gram(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    for (uint32_t i = 0; i < t->focus_count; i++) {
        double gii = gram_at(b, t, i, i);
        for (uint32_t j = 0; j < i; j++) {
            uint64_t off = t->gram_offset + ((uint64_t)i * t->focus_count + j) * 8;
            double gij = rdf64(b + off), gji = gram_at(b, t, j, i), gjj = gram_at(b, t, j, j);
            /* Cauchy-Schwarz, with slack for the rounding of exact integer sums to double. */
            if (!isfinite(gij) || gij != gji || fabs(gij) > sqrt(gii * gjj) * (1.0 + 1e-9))
                return fail(err, HAPTIC_TABLE_EGRAM, off,
                            "offset %llu (gram[%lu][%lu]): %g is not symmetric or violates Cauchy-Schwarz",
                            (unsigned long long)off, (unsigned long)i, (unsigned long)j, gij);
        }
    }
    return 0;
}

/* Length of the UTF-8 sequence at p (RFC 3629: shortest form, no surrogates,
 * at most U+10FFFF) and its code point, or 0 if invalid or cut at `end`. */
static size_t utf8_decode(const uint8_t *p, const uint8_t *end, uint32_t *cp)
{
    uint8_t c = p[0];
    size_t n;
    uint8_t lo = 0x80, hi = 0xBF; /* allowed range of the second byte */
    if (c < 0x80) {
        *cp = c;
        return 1;
    } else if (c >= 0xC2 && c <= 0xDF) {
        n = 2;
        *cp = c & 0x1F;
    } else if (c >= 0xE0 && c <= 0xEF) {
        n = 3;
        *cp = c & 0x0F;
        if (c == 0xE0)
            lo = 0xA0;
        if (c == 0xED)
            hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
        n = 4;
        *cp = c & 0x07;
        if (c == 0xF0)
            lo = 0x90;
        if (c == 0xF4)
            hi = 0x8F;
    } else {
        return 0;
    }
    if ((size_t)(end - p) < n)
        return 0;
    for (size_t k = 1; k < n; k++) {
        uint8_t lim_lo = k == 1 ? lo : 0x80, lim_hi = k == 1 ? hi : 0xBF;
        if (p[k] < lim_lo || p[k] > lim_hi)
            return 0;
        *cp = (*cp << 6) | (p[k] & 0x3F);
    }
    return n;
}

/* NUL-padded UTF-8 without control characters (C0, DEL, C1): safe to print. */
static int check_text(const uint8_t *p, uint64_t off, size_t len, const char *name, size_t *text_len,
                      haptic_table_error *err)
{
    size_t n = 0;
    while (n < len && p[n] != 0) {
        uint32_t cp;
        size_t k = utf8_decode(p + n, p + len, &cp);
        if (k == 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + n, "offset %llu (provenance %s): not valid UTF-8",
                        (unsigned long long)(off + n), name);
        if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F))
            return fail(err, HAPTIC_TABLE_EFIELD, off + n, "offset %llu (provenance %s): control character U+%04lX",
                        (unsigned long long)(off + n), name, (unsigned long)cp);
        n += k;
    }
    *text_len = n;
    for (size_t i = n; i < len; i++)
        if (p[i] != 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + i, "offset %llu (provenance %s): bytes after the terminator",
                        (unsigned long long)(off + i), name);
    return 0;
}

static bool is_digit(uint8_t c) { return c >= '0' && c <= '9'; }
static bool is_lower(uint8_t c) { return c >= 'a' && c <= 'z'; }
static bool is_hex(uint8_t c) { return is_digit(c) || (c >= 'a' && c <= 'f'); }

/* `algorithm:hex`: algorithm [a-z][a-z0-9-]*, hex a whole number of bytes in
 * lower-case hex digits. Returns the index of the first offending byte or -1. */
static long scene_hash_fault(const uint8_t *p, size_t n)
{
    size_t i = 0;
    if (n == 0 || !is_lower(p[0]))
        return 0;
    while (i < n && (is_lower(p[i]) || is_digit(p[i]) || p[i] == '-'))
        i++;
    if (i == n || p[i] != ':')
        return (long)i;
    size_t h = ++i;
    while (i < n && is_hex(p[i]))
        i++;
    if (i < n)
        return (long)i;
    if (n == h || (n - h) % 2 != 0)
        return (long)n - 1;
    return -1;
}

/* YYYY-MM-DDTHH:MM:SSZ (UTC, ISO 8601 basic calendar form, second 60 for a
 * leap second). Returns the index of the first offending byte or -1. */
static long created_fault(const uint8_t *p, size_t n)
{
    static const char form[] = "dddd-dd-ddTdd:dd:ddZ";
    for (size_t i = 0; i < sizeof form - 1; i++) {
        if (i >= n)
            return (long)n;
        if (form[i] == 'd' ? !is_digit(p[i]) : p[i] != (uint8_t)form[i])
            return (long)i;
    }
    if (n != sizeof form - 1)
        return (long)(sizeof form - 1);
    struct {
        size_t at;
        int lo, hi;
    } ranges[] = {{5, 1, 12}, {8, 1, 31}, {11, 0, 23}, {14, 0, 59}, {17, 0, 60}};
    for (size_t k = 0; k < sizeof ranges / sizeof *ranges; k++) {
        int v = (p[ranges[k].at] - '0') * 10 + (p[ranges[k].at + 1] - '0');
        if (v < ranges[k].lo || v > ranges[k].hi)
            return (long)ranges[k].at;
    }
    return -1;
}

static int check_provenance(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    static const struct {
        unsigned off;
        const char *name;
    } fields[] = {{PROV_SCENE_NAME, "scene_name"},
                  {PROV_SCENE_HASH, "scene_hash"},
                  {PROV_TOOL_VERSION, "tool_version"},
                  {PROV_CREATED, "created_utc"}};
    for (int i = 0; i < 4; i++) {
        const uint64_t off = t->provenance_offset + fields[i].off;
        const uint8_t *p = b + off;
        size_t n = 0;
        int rc = check_text(p, off, 64, fields[i].name, &n, err);
        if (rc)
            return rc;
        if (n == 0) /* an empty field says "not known" */
            continue;
        long at = fields[i].off == PROV_SCENE_HASH ? scene_hash_fault(p, n)
                  : fields[i].off == PROV_CREATED  ? created_fault(p, n)
                                                   : -1;
        if (at >= 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + (uint64_t)at, "offset %llu (provenance %s): not of the form %s",
                        (unsigned long long)(off + (uint64_t)at), fields[i].name,
                        fields[i].off == PROV_SCENE_HASH ? "algorithm:hex" : "YYYY-MM-DDTHH:MM:SSZ");
    }
    return 0;
}

static int gram_mismatch(const uint8_t *b, const haptic_table *t, const int16_t *s, uint64_t per_focus, uint32_t i,
                         uint32_t j, haptic_table_error *err)
{
    const uint64_t off = t->gram_offset + ((uint64_t)i * t->focus_count + j) * 8;
    const double want = (double)haptic_table_dot_(s + i * per_focus, s + j * per_focus, per_focus);
    const double got = rdf64(b + off);
    if (got != want)
        return fail(err, HAPTIC_TABLE_EGRAM, off, "offset %llu (gram[%lu][%lu]): %.17g, the payload gives %.17g",
                    (unsigned long long)off, (unsigned long)i, (unsigned long)j, got, want);
    return 0;
}

/* The Gram matrix against its definition: the exact integer sums over the
 * payload, rounded once to binary64. First the whole diagonal (O(K N C), the
 * cost of the CRC), then the lower triangle row by row while the work stays
 * within HAPTIC_TABLE_GRAM_FULL_CHECK_MAX_PRODUCTS. */
static int check_payload(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    const uint64_t per_focus = (uint64_t)t->samples_per_signal * t->channel_count;
    const int16_t *s = (const int16_t *)(const void *)(b + t->payload_offset);
    int rc;
    for (uint32_t f = 0; f < t->focus_count; f++)
        if ((rc = gram_mismatch(b, t, s, per_focus, f, f, err)))
            return rc;
    const uint64_t pairs = (uint64_t)t->focus_count * (t->focus_count - 1) / 2;
    if (pairs > HAPTIC_TABLE_GRAM_FULL_CHECK_MAX_PRODUCTS / per_focus)
        return 0;
    for (uint32_t i = 1; i < t->focus_count; i++)
        for (uint32_t j = 0; j < i; j++)
            if ((rc = gram_mismatch(b, t, s, per_focus, i, j, err)))
                return rc;
    return 0;
}

int haptic_table_check_content_(const uint8_t *b, const haptic_table *t, haptic_table_error *err)
{
    int rc;
    if ((rc = check_reserved(b, t, err)) || (rc = check_channels(b, t, err)) || (rc = check_foci(b, t, err)) ||
        (rc = check_playback(b, t, err)) || (rc = check_panel(b, t, err)) || (rc = check_range(b, t, err)) ||
        (rc = check_gram(b, t, err)) || (rc = check_provenance(b, t, err)) || (rc = check_payload(b, t, err)))
        return rc;
    return 0;
}
