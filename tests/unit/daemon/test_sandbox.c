/* daemon/sandbox: what a program run in it can see and do, and how each
 * of its ends is reported. Needs bubblewrap (deploy/deps.sh installs it). */
#include <criterion/criterion.h>
#include <dirent.h>
#include <signal.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "sandbox.h"

static rd_sandbox_result run_files(const char *const *argv, const rd_sandbox_file *files, size_t nfiles, double wall_ms)
{
    rd_sandbox_spec sp = rd_sandbox_spec_default();
    sp.bwrap = "/usr/bin/bwrap";
    sp.argv = argv;
    sp.files = files;
    sp.nfiles = nfiles;
    sp.wall_ms = wall_ms;
    rd_sandbox_result r;
    rd_error err = {0};
    cr_assert_eq(rd_sandbox_run(&sp, &r, &err), RD_OK, "the sandbox did not start: %s", err.message);
    return r;
}

static rd_sandbox_result run(const char *const *argv) { return run_files(argv, NULL, 0, 10000); }

static void assert_exit(const rd_sandbox_result *r, int status)
{
    cr_assert_eq(r->end, RD_SANDBOX_EXITED, "ended %d (status %d), output: %s", (int)r->end, r->status, r->output);
    cr_assert_eq(r->status, status, "exit status %d, output: %s", r->status, r->output);
}

Test(sandbox, runs_as_nobody_with_a_cleared_environment)
{
    const char *const id[] = {"/usr/bin/id", "-u", NULL};
    rd_sandbox_result r = run(id);
    assert_exit(&r, 0);
    if (getuid() == 0) /* root's sandbox drops to 65534; anyone else stays who they are */
        cr_assert_str_eq(r.output, "65534\n");
    rd_sandbox_result_free(&r);
    setenv("RAYD_SECRET_FOR_THE_TEST", "leak", 1);
    const char *const env[] = {"/usr/bin/env", NULL};
    r = run(env);
    assert_exit(&r, 0);
    cr_assert_null(strstr(r.output, "RAYD_SECRET"), "the caller's environment leaked: %s", r.output);
    cr_assert_not_null(strstr(r.output, "HOME=/work"), "%s", r.output);
    rd_sandbox_result_free(&r);
}

Test(sandbox, sees_no_host_file_and_no_network)
{
    const char *const passwd[] = {"/usr/bin/cat", "/etc/passwd", NULL};
    rd_sandbox_result r = run(passwd);
    cr_assert(r.end == RD_SANDBOX_EXITED && r.status != 0, "/etc/passwd is readable: %s", r.output);
    cr_assert_null(strstr(r.output, "root:"), "%s", r.output);
    rd_sandbox_result_free(&r);
    const char *const net[] = {"/usr/bin/cat", "/proc/net/dev", NULL};
    r = run(net);
    assert_exit(&r, 0);
    /* two header lines, then loopback only */
    int lines = 0;
    for (const char *p = r.output; *p; p++)
        lines += *p == '\n';
    cr_assert_eq(lines, 3, "interfaces besides lo: %s", r.output);
    rd_sandbox_result_free(&r);
}

Test(sandbox, copies_files_in_and_reads_fd_3)
{
    static const char text[] = "copied in\n";
    rd_sandbox_file f = {"/work/in.txt", NULL, text, sizeof text - 1, 0};
    const char *const argv[] = {"/usr/bin/sh", "-c", "cat /work/in.txt; printf 'to the caller' >&3", NULL};
    rd_sandbox_result r = run_files(argv, &f, 1, 10000);
    assert_exit(&r, 0);
    cr_assert_str_eq(r.output, text);
    cr_assert_eq(r.data_len, 13);
    cr_assert_eq(memcmp(r.data, "to the caller", 13), 0);
    rd_sandbox_result_free(&r);
}

Test(sandbox, a_crash_is_its_signal)
{
    const char *const argv[] = {"/usr/bin/sh", "-c", "kill -SEGV $$", NULL};
    rd_sandbox_result r = run(argv);
    cr_assert_eq(r.end, RD_SANDBOX_SIGNALED, "ended %d", (int)r.end);
    cr_assert_eq(r.status, SIGSEGV);
    rd_sandbox_result_free(&r);
}

Test(sandbox, the_wall_clock_kills_the_whole_tree)
{
    const char *const argv[] = {"/usr/bin/sh", "-c", "sleep 30 & sleep 30", NULL};
    rd_sandbox_result r = run_files(argv, NULL, 0, 500);
    cr_assert_eq(r.end, RD_SANDBOX_TIMED_OUT, "ended %d", (int)r.end);
    cr_assert_lt(r.ms, 5000, "took %.0f ms to stop", r.ms);
    rd_sandbox_result_free(&r);
}

Test(sandbox, output_past_the_limit_ends_the_run)
{
    const char *const argv[] = {"/usr/bin/yes", NULL};
    rd_sandbox_result r = run(argv);
    cr_assert_eq(r.end, RD_SANDBOX_OUTPUT_LIMIT, "ended %d", (int)r.end);
    cr_assert_leq(r.output_len, rd_sandbox_spec_default().output_max);
    rd_sandbox_result_free(&r);
}

Test(sandbox, a_file_past_the_size_limit_is_refused)
{
    const char *const argv[] = {"/usr/bin/sh", "-c", "head -c 20000000 /dev/zero > /tmp/big; echo $?", NULL};
    rd_sandbox_result r = run(argv);
    /* RLIMIT_FSIZE (16 MiB) or the 64 MiB tmpfs: head is stopped by SIGXFSZ */
    cr_assert_eq(r.end, RD_SANDBOX_EXITED, "ended %d", (int)r.end);
    cr_assert_str_neq(r.output, "0\n", "a 20 MB file was written");
    rd_sandbox_result_free(&r);
}

Test(sandbox, cancel_stops_it)
{
    atomic_int cancel = 1;
    rd_sandbox_spec sp = rd_sandbox_spec_default();
    const char *const argv[] = {"/usr/bin/sleep", "30", NULL};
    sp.bwrap = "/usr/bin/bwrap";
    sp.argv = argv;
    sp.cancel = &cancel;
    rd_sandbox_result r;
    rd_error err = {0};
    cr_assert_eq(rd_sandbox_run(&sp, &r, &err), RD_OK, "%s", err.message);
    cr_assert_eq(r.end, RD_SANDBOX_CANCELLED);
    rd_sandbox_result_free(&r);
}

Test(sandbox, no_bubblewrap_is_an_error_and_nothing_runs)
{
    rd_error err = {0};
    cr_assert_eq(rd_sandbox_probe("/nonexistent/bwrap", &err), RD_ERR_UNAVAILABLE);
    cr_assert_not_null(strstr(err.message, "bubblewrap"), "%s", err.message);
    cr_assert_eq(rd_sandbox_probe("/usr/bin/bwrap", &err), RD_OK, "%s", err.message);
}

/* Entries of /proc/self/fd, the directory's own one included. */
static int open_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    cr_assert_not_null(d);
    int n = 0;
    while (readdir(d))
        n++;
    closedir(d);
    return n;
}

Test(sandbox, runs_leave_no_descriptor_open, .timeout = 120)
{
    const char *const argv[] = {"/usr/bin/true", NULL};
    rd_sandbox_result r = run(argv);
    rd_sandbox_result_free(&r);
    int before = open_fds();
    for (int i = 0; i < 1000; i++) {
        r = run(argv);
        assert_exit(&r, 0);
        rd_sandbox_result_free(&r);
    }
    cr_assert_eq(open_fds(), before, "1000 runs: %d descriptors open, %d before", open_fds(), before);
}

/* A caller under a small descriptor limit (a daemon given LimitNOFILE=64)
 * still starts a sandbox with files: nothing needs a high descriptor. */
Test(sandbox, starts_under_a_small_descriptor_limit)
{
    struct rlimit rl = {32, 32};
    cr_assert_eq(setrlimit(RLIMIT_NOFILE, &rl), 0);
    static const char text[] = "in\n";
    rd_sandbox_file f = {"/work/in.txt", NULL, text, sizeof text - 1, 0};
    const char *const argv[] = {"/usr/bin/cat", "/work/in.txt", NULL};
    rd_sandbox_result r = run_files(argv, &f, 1, 10000);
    assert_exit(&r, 0);
    cr_assert_str_eq(r.output, text);
    rd_sandbox_result_free(&r);
}
