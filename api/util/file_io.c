#include "file_io.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "rayd/memory.h"
#include "rayd/parallel.h"

/* Bytes [first, first + count) of the file into buf + first; a read error
 * or a file that ended early clears ok. */
typedef struct {
    int fd;
    char *buf;
    atomic_int ok;
} pieces;

static void read_piece(void *ctx, size_t first, size_t count)
{
    pieces *p = ctx;
    size_t got = 0;
    while (got < count) {
        ssize_t k = pread(p->fd, p->buf + first + got, count - got, (off_t)(first + got));
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            break;
        got += (size_t)k;
    }
    if (got != count)
        atomic_store(&p->ok, 0);
}

/* Below twice this a file is read on one thread. The pieces are read at
 * once because the buffer's pages are first written (and zeroed by the
 * kernel) by the thread that reads into them. */
enum { PIECE_MIN = 8 << 20 };

rd_error_code rd_read_file(const char *path, size_t max_bytes, const char *flag, char **out, size_t *len, rd_error *err)
{
    return rd_read_file_threads(path, max_bytes, flag, 1, out, len, err);
}

rd_error_code rd_read_file_threads(const char *path, size_t max_bytes, const char *flag, int threads, char **out,
                                   size_t *len, rd_error *err)
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
    char *buf = rd_big_malloc(n + 1);
    if (!buf) {
        close(fd);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", path);
    }
    pieces ps = {fd, buf, 1};
    rd_parallel_runs(n, PIECE_MIN, threads, read_piece, &ps);
    int ok = atomic_load(&ps.ok);
    /* A file that grew since fstat is read as it was then; one that shrank
     * is a read error. */
    close(fd);
    if (!ok) {
        free(buf);
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: read error", path);
    }
    buf[n] = 0;
    *out = buf;
    *len = n;
    return RD_OK;
}

/* The temporary file rd_write_file writes path through, malloc'ed; NULL
 * when out of memory. */
static char *temp_name(const char *path)
{
    size_t n = strlen(path) + 32;
    char *tmp = malloc(n);
    if (tmp)
        snprintf(tmp, n, "%s.tmp%ld", path, (long)getpid());
    return tmp;
}

int rd_is_special_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

/* A special file, written in place. */
static rd_error_code write_special(const char *path, const void *data, size_t len, rd_error *err)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
    size_t put = fwrite(data, 1, len, f);
    if ((put != len) | (fclose(f) != 0))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
    return RD_OK;
}

rd_error_code rd_check_writable(const char *path, rd_error *err)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(EISDIR));
    if (rd_is_special_file(path))
        return access(path, W_OK) == 0
                   ? RD_OK
                   : rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
    char *tmp = temp_name(path);
    if (!tmp)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    rd_error_code rc = RD_OK;
    if (fd < 0)
        rc = rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
    else
        close(fd);
    if (fd >= 0)
        remove(tmp);
    free(tmp);
    return rc;
}

rd_error_code rd_write_file(const char *path, const void *data, size_t len, rd_error *err)
{
    if (rd_is_special_file(path))
        return write_special(path, data, len, err);
    char *tmp = temp_name(path);
    if (!tmp)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        rd_error_code rc = rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
        free(tmp);
        return rc;
    }
    size_t put = fwrite(data, 1, len, f);
    int bad = (put != len) | (fclose(f) != 0);
    if (bad || rename(tmp, path) != 0) {
        rd_error_code rc = rd_error_set(err, RD_ERR_IO, 0, 0, "%s: cannot write: %s", path, strerror(errno));
        remove(tmp);
        free(tmp);
        return rc;
    }
    free(tmp);
    return RD_OK;
}

char *rd_dirname(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return strdup(".");
    if (slash == path)
        return strdup("/");
    size_t n = (size_t)(slash - path);
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = 0;
    }
    return d;
}

int rd_ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}
