/* text.h - what counts as text in what hapticd is given (trigger lines,
 * board files) and how anything else is shown: printable ASCII, tab and
 * valid UTF-8 but the C1 controls (U+0080..U+009F: CSI and NEL act on
 * terminals too) are text; every other byte (control bytes, DEL, NUL, the
 * C1 controls' bytes, bytes of no valid UTF-8 sequence: a lone continuation
 * byte, an overlong form, a surrogate, a cut sequence) is shown as \xNN, and
 * a backslash as \\.
 * Pure functions: no allocation, no I/O. */
#ifndef HD_TEXT_H
#define HD_TEXT_H

#include <stddef.h>

/* Length of the valid UTF-8 sequence of two or more bytes at s (at most n
 * bytes available), or 0: no overlong forms, no surrogates, nothing above
 * U+10FFFF. */
size_t hd_text_utf8_sequence(const unsigned char *s, size_t n);

/* src[0..len) escaped into dst (always NUL-terminated, cut at a whole escape
 * or character when dst is full). Returns the number of source bytes
 * consumed (< len when cut). */
size_t hd_text_escape(char *dst, size_t cap, const char *src, size_t len);

/* NULL if line[0..len) is text (tab and CR allowed); otherwise what the
 * first offending byte is ("a NUL byte", "a control byte", "a byte that is
 * not UTF-8"), its 1-based column in *column. */
const char *hd_text_check_line(const char *line, size_t len, size_t *column);

#endif
