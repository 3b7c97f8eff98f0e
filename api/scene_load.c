#include "scene_load.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cfg_parse.h"
#include "json_parse.h"

rd_scene_format rd_scene_sniff(const char *text, size_t len)
{
    size_t i = 0;
    if (len >= 3 && memcmp(text, "\xef\xbb\xbf", 3) == 0)
        i = 3;
    while (i < len && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r' || text[i] == '\n'))
        i++;
    return i < len && text[i] == '{' ? RD_FMT_JSON : RD_FMT_CFG;
}

rd_error_code rd_scene_parse(const char *text, size_t len, rd_scene_format fmt, const char *source,
                             const rd_scene_limits *lim, rd_scene *s, rd_error *err)
{
    if (fmt == RD_FMT_AUTO)
        fmt = rd_scene_sniff(text, len);
    if (fmt == RD_FMT_JSON)
        return rd_json_parse(text, len, source, lim, s, err);
    return rd_cfg_parse(text, len, source, lim, s, err);
}

rd_error_code rd_read_file(const char *path, size_t max_bytes, const char *flag, char **out, size_t *len,
                           rd_error *err)
{
    *out = NULL;
    *len = 0;
    /* Non-blocking, so that opening a FIFO or a device cannot hang the
     * caller; the type is checked on the descriptor before any read. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: not a regular file", path);
    }
    if ((unsigned long long)st.st_size > max_bytes) {
        close(fd);
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "%s: %lld bytes, over the limit of %zu (%s)", path,
                            (long long)st.st_size, max_bytes, flag);
    }
    size_t n = (size_t)st.st_size;
    char *buf = malloc(n + 1);
    if (!buf) {
        close(fd);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", path);
    }
    size_t got = 0;
    while (got < n) {
        ssize_t k = read(fd, buf + got, n - got);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            break;
        got += (size_t)k;
    }
    close(fd);
    if (got != n) {
        free(buf);
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: read error", path);
    }
    buf[n] = 0;
    *out = buf;
    *len = n;
    return RD_OK;
}

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

rd_error_code rd_scene_load_file(const char *path, const rd_scene_limits *lim_in, rd_scene *s,
                                 rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    char *text;
    size_t len;
    rd_error_code rc = rd_read_file(path, lim.max_bytes, rd_limit_flag(offsetof(rd_scene_limits, max_bytes)),
                                    &text, &len, err);
    if (rc)
        return rc;
    rd_scene_format fmt = ends_with(path, ".json") ? RD_FMT_JSON
                        : ends_with(path, ".cfg")  ? RD_FMT_CFG
                                                   : RD_FMT_AUTO;
    rc = rd_scene_parse(text, len, fmt, path, &lim, s, err);
    free(text);
    return rc;
}
