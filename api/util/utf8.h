/* UTF-8 checks for scene text. */
#ifndef RD_UTF8_H
#define RD_UTF8_H

#include <stddef.h>

/* Offset of the first byte that is not part of valid UTF-8 (overlongs,
 * surrogates and code points above U+10FFFF are invalid), or len if all is
 * valid. A NUL byte counts as invalid here: scene text never contains one. */
size_t rd_utf8_invalid_at(const char *s, size_t len);

/* Bytes of the longest prefix of s (len bytes) holding at most max_chars
 * characters and no split character: for cutting text in messages. */
size_t rd_utf8_prefix(const char *s, size_t len, size_t max_chars);

/* Writes the len bytes at s into out (size >= 1) as readable UTF-8 text,
 * NUL-terminated: each byte that is not part of a valid UTF-8 character
 * becomes the three characters %HH (its value in hex, as in a URL: a
 * Latin-1 m\xfcller is m%FCller), each control character (below 0x20,
 * 0x7f; NUL included) '_'; the text is cut at a character boundary to
 * size - 1 bytes. Returns 1 when all len bytes are UTF-8 (a NUL counts
 * as not), 0 when some byte is not, written or cut off. For names from
 * outside (file names, form fields) that must be shown and stored as
 * text, and say when they were not. */
int rd_utf8_readable(const char *s, size_t len, char *out, size_t size);

/* 1-based character column of offset pos in the line starting at line_start. */
int rd_utf8_column(const char *line_start, const char *pos);

/* 3 when text begins with a UTF-8 byte-order mark, else 0. */
size_t rd_utf8_bom(const char *text, size_t len);

/* The 1-based line and character column of byte offset off; a byte-order
 * mark at the start counts for no column. */
void rd_utf8_position(const char *text, size_t len, size_t off, int *line, int *column);

#endif
