#include "pg_server.h"

#include <arpa/inet.h>
#include <criterion/criterion.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static void nap_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* The highest /usr/lib/postgresql/N/bin holding initdb and pg_ctl, or
 * $RAYD_PG_BIN. */
static int find_bin(char *out, size_t size)
{
    const char *env = getenv("RAYD_PG_BIN");
    if (env && *env) {
        snprintf(out, size, "%s", env);
        return 1;
    }
    int best = -1;
    DIR *d = opendir("/usr/lib/postgresql");
    for (struct dirent *e; d && (e = readdir(d));) {
        char path[300];
        int v = atoi(e->d_name);
        snprintf(path, sizeof path, "/usr/lib/postgresql/%d/bin/pg_ctl", v);
        if (v > best && access(path, X_OK) == 0) {
            best = v;
            snprintf(out, size, "/usr/lib/postgresql/%d/bin", v);
        }
    }
    if (d)
        closedir(d);
    return best >= 0;
}

static const char *runuser_path(void)
{
    static const char *const paths[] = {"/usr/sbin/runuser", "/sbin/runuser", "/usr/bin/runuser"};
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++)
        if (access(paths[i], X_OK) == 0)
            return paths[i];
    return NULL;
}

/* The last lines of the server's log, for a failure's message. */
static const char *log_tail(const pg_server *s)
{
    static char tail[1500];
    char path[128];
    snprintf(path, sizeof path, "%s/server.log", s->dir);
    tail[0] = '\0';
    FILE *f = fopen(path, "r");
    if (!f)
        return "(no log)";
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, n > (long)sizeof tail - 1 ? n - (long)sizeof tail + 1 : 0, SEEK_SET);
    size_t got = fread(tail, 1, sizeof tail - 1, f);
    tail[got] = '\0';
    fclose(f);
    return tail;
}

/* Runs bin/tool with args as the server's user, output appended to the
 * log; its exit status, or -1 past timeout_s. */
static int run_tool(const pg_server *s, const char *tool, const char *const *args, double timeout_s)
{
    const char *argv[24];
    char exe[300];
    int n = 0;
    snprintf(exe, sizeof exe, "%s/%s", s->bin, tool);
    if (geteuid() == 0) {
        argv[n++] = runuser_path();
        argv[n++] = "-u";
        argv[n++] = "postgres";
        argv[n++] = "--";
    }
    argv[n++] = exe;
    for (int i = 0; args[i] && n < 23; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    char log[128];
    snprintf(log, sizeof log, "%s/server.log", s->dir);
    pid_t pid = fork();
    cr_assert_geq(pid, 0, "fork: %s", strerror(errno));
    if (pid == 0) {
        int lf = open(log, O_WRONLY | O_CREAT | O_APPEND, 0644);
        int nul = open("/dev/null", O_RDONLY);
        if (lf < 0 || nul < 0 || chdir(s->dir) != 0)
            _exit(126);
        dup2(nul, 0);
        dup2(lf, 1);
        dup2(lf, 2);
        /* The server must not hold the test runner's descriptors open. */
        for (int fd = 3; fd < 1024; fd++)
            close(fd);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    int st = 0;
    for (double waited = 0; waited < timeout_s; waited += 0.01) {
        if (waitpid(pid, &st, WNOHANG) == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        nap_ms(10);
    }
    kill(pid, SIGKILL);
    waitpid(pid, &st, 0);
    return -1;
}

static int free_port(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t len = sizeof a;
    cr_assert(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof a) == 0 &&
                  getsockname(fd, (struct sockaddr *)&a, &len) == 0,
              "no free port on 127.0.0.1: %s", strerror(errno));
    close(fd);
    return ntohs(a.sin_port);
}

static pid_t read_pid(const pg_server *s)
{
    char path[128];
    snprintf(path, sizeof path, "%s/data/postmaster.pid", s->dir);
    FILE *f = fopen(path, "r");
    long pid = 0;
    if (f) {
        if (fscanf(f, "%ld", &pid) != 1)
            pid = 0;
        fclose(f);
    }
    return (pid_t)pid;
}

static int start_once(pg_server *s)
{
    char data[96], opts[400];
    snprintf(data, sizeof data, "%s/data", s->dir);
    /* fsync and friends off: a test's data need not survive the machine. */
    snprintf(opts, sizeof opts,
             "-c listen_addresses=127.0.0.1 -p %d -c unix_socket_directories=%s -c fsync=off "
             "-c full_page_writes=off -c synchronous_commit=off -c max_connections=40 -c shared_buffers=16MB",
             s->port, s->dir);
    const char *args[] = {"-D", data, "-w", "-t", "30", "-o", opts, "start", NULL};
    if (run_tool(s, "pg_ctl", args, 40) != 0)
        return 0;
    s->pid = read_pid(s);
    return s->pid > 0;
}

/* name: letters, digits and _ only (it is written into the statement). */
static void create_database(pg_server *s, const char *name)
{
    char info[160], sql[96];
    snprintf(info, sizeof info, "host=127.0.0.1 port=%d dbname=postgres user=postgres connect_timeout=5", s->port);
    PGconn *c = PQconnectdb(info);
    cr_assert_eq(PQstatus(c), CONNECTION_OK, "connecting to the test server: %s", PQerrorMessage(c));
    snprintf(sql, sizeof sql, "CREATE DATABASE %s", name);
    PGresult *r = PQexec(c, sql);
    cr_assert_eq(PQresultStatus(r), PGRES_COMMAND_OK, "CREATE DATABASE: %s", PQerrorMessage(c));
    PQclear(r);
    PQfinish(c);
    snprintf(s->conninfo, sizeof s->conninfo, "host=127.0.0.1 port=%d dbname=%s user=postgres", s->port, name);
    snprintf(s->url, sizeof s->url, "postgresql://postgres@127.0.0.1:%d/%s", s->port, name);
}

static void remove_tree(const char *dir)
{
    pid_t pid = fork();
    if (pid == 0) {
        execl("/bin/rm", "rm", "-rf", dir, (char *)NULL);
        _exit(127);
    }
    if (pid > 0)
        waitpid(pid, NULL, 0);
}

static void stop_and_remove(pg_server *s)
{
    pid_t pm = read_pid(s);
    if (pm > 0) {
        const char *args[] = {"-D", "data", "-m", "immediate", "-w", "stop", NULL};
        if (run_tool(s, "pg_ctl", args, 20) != 0)
            kill(pm, SIGKILL);
    }
    remove_tree(s->dir);
}

static void close_inherited(int keep)
{
    for (int fd = 3; fd < 1024; fd++)
        if (fd != keep)
            close(fd);
}

/* Waits for EOF on its pipe (the test process closed it or died), then
 * stops whatever still runs and removes the folder. */
static void start_guard(pg_server *s)
{
    int p[2];
    cr_assert_eq(pipe(p), 0);
    pid_t pid = fork();
    cr_assert_geq(pid, 0);
    if (pid == 0) {
        close_inherited(p[0]);
        char c;
        for (;;) {
            ssize_t r = read(p[0], &c, 1);
            if (r == 0 || (r < 0 && errno != EINTR))
                break;
        }
        stop_and_remove(s);
        _exit(0);
    }
    close(p[0]);
    fcntl(p[1], F_SETFD, FD_CLOEXEC);
    s->guard = pid;
    s->guard_fd = p[1];
}

static void prepare_folder(pg_server *s)
{
    struct stat sb;
    cr_assert(stat("/dev/null", &sb) == 0 && S_ISCHR(sb.st_mode),
              "/dev/null is not a device (something replaced it with a file): PostgreSQL's initdb needs it "
              "(mknod -m 666 /dev/null c 1 3 restores it)");
    cr_assert(find_bin(s->bin, sizeof s->bin),
              "PostgreSQL's server binaries are missing (no /usr/lib/postgresql/N/bin/pg_ctl, $RAYD_PG_BIN unset): "
              "install the Debian package postgresql (make deps)");
    snprintf(s->dir, sizeof s->dir, "/tmp/rayd-pg.XXXXXX");
    cr_assert(mkdtemp(s->dir), "mkdtemp: %s", strerror(errno));
    if (geteuid() == 0) {
        struct passwd *pw = getpwnam("postgres");
        cr_assert(pw, "running as root, the server needs the user postgres (made by the package postgresql)");
        cr_assert(runuser_path(), "running as root, the server's commands need runuser (util-linux)");
        cr_assert_eq(chown(s->dir, pw->pw_uid, pw->pw_gid), 0, "chown %s: %s", s->dir, strerror(errno));
    }
}

static void init_and_start(pg_server *s)
{
    const char *args[] = {"-D", "data", "-N", "-A", "trust", "-U", "postgres", "-E", "UTF8", "--locale=C", NULL};
    cr_assert_eq(run_tool(s, "initdb", args, 60), 0, "initdb failed in %s:\n%s", s->dir, log_tail(s));
    /* The port was free a moment ago; another process may take it first. */
    int started = 0;
    for (int tries = 0; tries < 3 && !started; tries++) {
        s->port = free_port();
        started = start_once(s);
    }
    cr_assert(started, "the test server did not start (%s):\n%s", s->dir, log_tail(s));
}

void pg_server_start(pg_server *s)
{
    memset(s, 0, sizeof *s);
    s->guard_fd = -1;
    prepare_folder(s);
    start_guard(s);
    init_and_start(s);
    create_database(s, "rayd_test");
}

/* The shared server's guard: detached from the test process (which ends
 * long before the run), it polls the runner and cleans up after it. */
static void start_runner_guard(pg_server *s, pid_t runner, const char *info, const char *lock)
{
    pid_t pid = fork();
    cr_assert_geq(pid, 0);
    if (pid == 0) {
        setsid();
        if (fork() != 0)
            _exit(0);
        close_inherited(-1);
        while (kill(runner, 0) == 0)
            nap_ms(200);
        stop_and_remove(s);
        unlink(info);
        unlink(lock);
        _exit(0);
    }
    waitpid(pid, NULL, 0);
}

/* The shared server's folder and port, if it runs. */
static int read_shared(pg_server *s, const char *info)
{
    FILE *f = fopen(info, "r");
    if (!f)
        return 0;
    int ok = fscanf(f, "%63s %d", s->dir, &s->port) == 2;
    fclose(f);
    return ok && read_pid(s) > 0 && kill(read_pid(s), 0) == 0;
}

void pg_server_shared(pg_server *s)
{
    memset(s, 0, sizeof *s);
    s->guard_fd = -1;
    s->shared = 1;
    pid_t runner = getppid();
    char info[96], lock[96], name[64];
    snprintf(info, sizeof info, "/tmp/rayd-pg-shared.%d", (int)runner);
    snprintf(lock, sizeof lock, "/tmp/rayd-pg-shared.%d.lock", (int)runner);
    int lf = open(lock, O_CREAT | O_RDWR | O_CLOEXEC, 0600);
    cr_assert(lf >= 0 && flock(lf, LOCK_EX) == 0, "%s: %s", lock, strerror(errno));
    if (!read_shared(s, info)) {
        prepare_folder(s);
        start_runner_guard(s, runner, info, lock);
        init_and_start(s);
        FILE *f = fopen(info, "w");
        cr_assert(f && fprintf(f, "%s %d\n", s->dir, s->port) > 0 && fclose(f) == 0, "%s", info);
    }
    cr_assert(find_bin(s->bin, sizeof s->bin));
    close(lf);
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    snprintf(name, sizeof name, "t%d_%ld", (int)getpid(), (long)ts.tv_nsec);
    create_database(s, name);
}

void pg_server_stop(pg_server *s)
{
    cr_assert(!s->shared, "the shared server is not to be stopped");
    if (s->pid <= 0)
        return;
    const char *args[] = {"-D", "data", "-m", "fast", "-w", "-t", "20", "stop", NULL};
    if (run_tool(s, "pg_ctl", args, 30) != 0)
        kill(s->pid, SIGKILL);
    for (int i = 0; i < 500 && kill(s->pid, 0) == 0; i++)
        nap_ms(10);
    s->pid = 0;
}

void pg_server_restart(pg_server *s)
{
    cr_assert_eq(s->pid, 0, "the test server runs already");
    cr_assert(start_once(s), "the test server did not start again:\n%s", log_tail(s));
}

void pg_server_destroy(pg_server *s)
{
    if (!s->dir[0] || s->shared)
        return;
    pg_server_stop(s);
    remove_tree(s->dir);
    if (s->guard_fd >= 0)
        close(s->guard_fd);
    if (s->guard > 0)
        waitpid(s->guard, NULL, 0);
    s->guard_fd = -1;
    s->guard = 0;
    s->dir[0] = '\0';
}
