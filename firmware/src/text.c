/* text.c - what counts as text (see text.h). */
#include "text.h"

#include <stdio.h>

/* Length of the valid UTF-8 sequence at s (at most n bytes), 0 if none:
 * no overlong forms, no surrogates, nothing above U+10FFFF. */
size_t hd_text_utf8_sequence(const unsigned char *s, size_t n)
{
    unsigned char c = s[0];
    size_t len;
    unsigned lo = 0x80, hi = 0xBF; /* the second byte's range */
    if (c >= 0xC2 && c <= 0xDF)
        len = 2;
    else if (c >= 0xE0 && c <= 0xEF) {
        len = 3;
        if (c == 0xE0)
            lo = 0xA0;
        else if (c == 0xED)
            hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
        len = 4;
        if (c == 0xF0)
            lo = 0x90;
        else if (c == 0xF4)
            hi = 0x8F;
    } else
        return 0;
    if (n < len || s[1] < lo || s[1] > hi)
        return 0;
    for (size_t i = 2; i < len; i++)
        if (s[i] < 0x80 || s[i] > 0xBF)
            return 0;
    return len;
}

/* U+0080..U+009F (C2 80..C2 9F): the C1 controls, CSI and NEL among them;
 * valid UTF-8, but control characters all the same. */
static int is_c1(const unsigned char *s) { return s[0] == 0xC2 && s[1] < 0xA0; }

size_t hd_text_escape(char *dst, size_t cap, const char *src, size_t len)
{
    static const char hex[] = "0123456789abcdef";
    const unsigned char *s = (const unsigned char *)src;
    size_t in = 0, out = 0;
    if (cap == 0)
        return 0;
    while (in < len) {
        unsigned char c = s[in];
        size_t take = 1, need;
        char esc[4];
        const char *piece = (const char *)s + in;
        if (c == '\\') {
            piece = "\\\\";
            need = 2;
        } else if (c >= 0x20 && c < 0x7F) {
            need = 1;
        } else if (c >= 0x80 && (take = hd_text_utf8_sequence(s + in, len - in)) != 0 && !is_c1(s + in)) {
            need = take;
        } else {
            take = 1;
            esc[0] = '\\';
            esc[1] = 'x';
            esc[2] = hex[c >> 4];
            esc[3] = hex[c & 15];
            piece = esc;
            need = 4;
        }
        if (out + need >= cap)
            break;
        for (size_t i = 0; i < need; i++)
            dst[out++] = piece[i];
        in += take;
    }
    dst[out] = '\0';
    return in;
}

const char *hd_text_check_line(const char *line, size_t len, size_t *column)
{
    const unsigned char *s = (const unsigned char *)line;
    for (size_t i = 0; i < len;) {
        unsigned char c = s[i];
        *column = i + 1;
        if (c == '\0')
            return "a NUL byte";
        if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7F)
            return "a control byte";
        if (c < 0x80) {
            i++;
            continue;
        }
        size_t n = hd_text_utf8_sequence(s + i, len - i);
        if (!n)
            return "a byte that is not UTF-8";
        if (is_c1(s + i))
            return "a control byte";
        i += n;
    }
    return NULL;
}
