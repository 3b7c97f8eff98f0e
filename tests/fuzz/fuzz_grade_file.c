/* libFuzzer target for the .grade reader (api/grading/assignment.c): an
 * assignment's thresholds and title, read whenever rayd grade or
 * POST /v1/grade names the assignment. Instructors write these files by
 * hand, so any bytes must give thresholds in range or an error with line
 * and column, never a crash.
 *
 * The reader is reached only through rd_assignment_load, which reads
 * DIR/NAME.grade beside DIR/NAME.cfg, so each input is written to
 * a.grade in a folder of its own, on tmpfs when there is one (/dev/shm),
 * and read back from there. The folder, rayd-fuzz-grade-PID, is removed at
 * exit; one left by a process that crashed is removed by the next run. (A
 * sanitizer death callback cannot do it: libFuzzer's own, which saves the
 * crashing input, is the only one there can be.) */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz_check.h"

#include "assignment.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static char dir[96], grade_path[128], cfg_path[128];

static void cleanup(void)
{
    if (!dir[0])
        return;
    unlink(grade_path);
    unlink(cfg_path);
    rmdir(dir);
    dir[0] = 0;
}

/* Folders of processes that no longer exist. */
static void remove_stale(const char *base)
{
    DIR *d = opendir(base);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        long pid;
        char end;
        if (sscanf(e->d_name, "rayd-fuzz-grade-%ld%c", &pid, &end) != 1 || pid <= 0 ||
            !(kill((pid_t)pid, 0) != 0 && errno == ESRCH))
            continue;
        char p[sizeof dir + 16];
        snprintf(p, sizeof p, "%s/%s/a.grade", base, e->d_name);
        unlink(p);
        snprintf(p, sizeof p, "%s/%s/a.cfg", base, e->d_name);
        unlink(p);
        snprintf(p, sizeof p, "%s/%s", base, e->d_name);
        rmdir(p);
    }
    closedir(d);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *bases[] = {"/dev/shm", getenv("TMPDIR"), "/tmp"};
    for (size_t i = 0; i < sizeof bases / sizeof bases[0] && !dir[0]; i++) {
        if (!bases[i] || !*bases[i] || strlen(bases[i]) > 60)
            continue;
        remove_stale(bases[i]);
        snprintf(dir, sizeof dir, "%s/rayd-fuzz-grade-%ld", bases[i], (long)getpid());
        if (mkdir(dir, 0700) != 0 && errno != EEXIST)
            dir[0] = 0;
    }
    if (!dir[0])
        rd_fuzz_fail("cannot create a temporary folder: %s", strerror(errno));
    snprintf(grade_path, sizeof grade_path, "%s/a.grade", dir);
    snprintf(cfg_path, sizeof cfg_path, "%s/a.cfg", dir);
    /* Only its existence matters to rd_assignment_load. */
    int fd = open(cfg_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0)
        rd_fuzz_fail("cannot create %s: %s", cfg_path, strerror(errno));
    close(fd);
    atexit(cleanup);
    return 0;
}

static void write_input(const uint8_t *data, size_t size)
{
    int fd = open(grade_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0)
        rd_fuzz_fail("cannot write %s: %s", grade_path, strerror(errno));
    size_t done = 0;
    while (done < size) {
        ssize_t k = write(fd, data + done, size - done);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            rd_fuzz_fail("cannot write %s: %s", grade_path, strerror(errno));
        done += (size_t)k;
    }
    close(fd);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    write_input(data, size);
    rd_assignment a;
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_assignment_load(dir, "a", &a, &err);
    if (rc == RD_OK) {
        /* What grading relies on, and the ranges assignment.h documents. */
        const rd_grade_thresholds *t = &a.thresholds;
        if (t->fail < 0 || t->fail > 255 || t->hard_fail < 0 || t->hard_fail > 255)
            rd_fuzz_fail("fail %d, hard_fail %d: outside 0..255", t->fail, t->hard_fail);
        if (!(t->fail_fraction >= 0 && t->fail_fraction <= 1))
            rd_fuzz_fail("fail_fraction %g outside [0, 1]", t->fail_fraction);
        if (t->hard_fail_pixels < 0)
            rd_fuzz_fail("hard_fail_pixels %d is negative", t->hard_fail_pixels);
        if (memchr(a.title, 0, sizeof a.title) == NULL || memchr(a.name, 0, sizeof a.name) == NULL)
            rd_fuzz_fail("title or name not terminated");
        if (strcmp(a.name, "a") != 0)
            rd_fuzz_fail("name '%s', expected 'a'", a.name);
        return 0;
    }
    if (err.code != rc || !err.message[0])
        rd_fuzz_fail("code %d with error code %d, message '%s'", (int)rc, (int)err.code, err.message);
    if (rc == RD_ERR_SYNTAX) {
        /* A syntax error names the file as it is named in its folder (never
         * the folder: answers over HTTP show no server path), its line and
         * its column. */
        if (strncmp(err.message, "a.grade:", 8) != 0)
            rd_fuzz_fail("message does not start with 'a.grade:': '%s'", err.message);
        if (err.line < 1 || err.column < 1)
            rd_fuzz_fail("position %d:%d in '%s'", err.line, err.column, err.message);
    } else if (rc != RD_ERR_LIMIT && rc != RD_ERR_IO) {
        rd_fuzz_fail("unexpected code %d: '%s'", (int)rc, err.message);
    }
    return 0;
}
