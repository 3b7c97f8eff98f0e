/* unit-filter UNIT PROGRAM ARGS...: runs PROGRAM under the namespace and
 * system-call restrictions of a systemd unit file, the way systemd would,
 * for tests on machines where PID 1 is not systemd. It reads the unit's
 * RestrictNamespaces=, SystemCallFilter=, SystemCallErrorNumber=,
 * RestrictAddressFamilies= and ProtectHostname= lines,
 * expands each @group with `systemd-analyze syscall-filter @group` (nested
 * groups too), installs the equivalent seccomp filter with no-new-privs,
 * and execs PROGRAM. Semantics as systemd.exec(5): the first
 * SystemCallFilter= decides whether the list allows (then everything else
 * is refused) or refuses; later lines add to it, "~" lines take away;
 * RestrictNamespaces=yes refuses every namespace, a list allows only those
 * named; clone3 is ENOSYS when namespaces are restricted, so that glibc
 * uses clone, whose flags can be read. Exit 125 when the unit or a group
 * cannot be read (never runs PROGRAM unfiltered). */
#define _GNU_SOURCE
#include <errno.h>
#include <sched.h>
#include <seccomp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <unistd.h>

enum { MAX_CALLS = 2048, LINE = 8192 };

typedef struct {
    char *names[MAX_CALLS];
    int allow[MAX_CALLS]; /* 1 listed, 0 taken away */
    int n;
    int mode; /* 0 no filter, 1 allow list, -1 deny list */
} calls;

static void die(const char *what)
{
    fprintf(stderr, "unit-filter: %s\n", what);
    exit(125);
}

static void set_call(calls *c, const char *name, int listed)
{
    for (int i = 0; i < c->n; i++)
        if (strcmp(c->names[i], name) == 0) {
            c->allow[i] = listed;
            return;
        }
    if (c->n == MAX_CALLS)
        die("too many system calls");
    c->names[c->n] = strdup(name);
    c->allow[c->n++] = listed;
}

static void add_name(calls *c, const char *name, int listed, int depth);

/* Every call of a group, its nested groups' included. */
static void add_group(calls *c, const char *group, int listed, int depth)
{
    char cmd[256], line[LINE];
    if (depth > 8 || strspn(group + 1, "abcdefghijklmnopqrstuvwxyz-") != strlen(group + 1))
        die("a bad group name");
    snprintf(cmd, sizeof cmd, "systemd-analyze syscall-filter %s 2>/dev/null", group);
    FILE *p = popen(cmd, "r");
    int got = 0;
    while (p && fgets(line, sizeof line, p)) {
        char word[128];
        if (line[0] != ' ' || sscanf(line, " %127s", word) != 1 || word[0] == '#')
            continue; /* the group's own name, a comment */
        add_name(c, word, listed, depth + 1);
        got++;
    }
    if (!p || pclose(p) != 0 || !got) {
        fprintf(stderr, "unit-filter: systemd-analyze cannot expand %s\n", group);
        exit(125);
    }
}

static void add_name(calls *c, const char *name, int listed, int depth)
{
    if (name[0] == '@')
        add_group(c, name, listed, depth);
    else
        set_call(c, name, listed);
}

/* One SystemCallFilter= value. */
static void filter_line(calls *c, char *value)
{
    int invert = value[0] == '~';
    if (c->mode == 0)
        c->mode = invert ? -1 : 1;
    /* in an allow list, "~" takes away; in a deny list, a plain line does */
    int listed = c->mode == 1 ? !invert : invert;
    for (char *w = strtok(value + invert, " \t\n"); w; w = strtok(NULL, " \t\n"))
        add_name(c, w, listed, 0);
}

/* RestrictNamespaces=: the CLONE_NEW* flags refused. */
static unsigned long ns_refused(const char *value)
{
    static const struct {
        const char *name;
        unsigned long flag;
    } ns[] = {{"cgroup", CLONE_NEWCGROUP}, {"ipc", CLONE_NEWIPC},   {"net", CLONE_NEWNET}, {"mnt", CLONE_NEWNS},
              {"pid", CLONE_NEWPID},       {"user", CLONE_NEWUSER}, {"uts", CLONE_NEWUTS}, {"time", 0x80}};
    unsigned long all = 0, listed = 0;
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++) {
        all |= ns[i].flag;
        const char *p = strstr(value, ns[i].name);
        if (p && (p == value || p[-1] == ' ' || p[-1] == '~'))
            listed |= ns[i].flag;
    }
    if (strncmp(value, "yes", 3) == 0)
        return all;
    if (strncmp(value, "no", 2) == 0)
        return 0;
    return value[0] == '~' ? listed : all & ~listed;
}

static void add_rule(scmp_filter_ctx ctx, uint32_t action, const char *name)
{
    int nr = seccomp_syscall_resolve_name(name);
    /* -EACCES: the action is the filter's default already */
    int rc = nr == __NR_SCMP_ERROR ? 0 : seccomp_rule_add(ctx, action, nr, 0);
    if (rc != 0 && rc != -EACCES)
        fprintf(stderr, "unit-filter: cannot add %s\n", name);
}

/* clone, unshare and setns with a refused flag; clone3 not there. */
static void restrict_ns(scmp_filter_ctx ctx, unsigned long refused, int err)
{
    for (unsigned long bit = 1; bit; bit <<= 1) {
        if (!(refused & bit))
            continue;
        seccomp_rule_add(ctx, SCMP_ACT_ERRNO(err), SCMP_SYS(clone), 1, SCMP_A0(SCMP_CMP_MASKED_EQ, bit, bit));
        seccomp_rule_add(ctx, SCMP_ACT_ERRNO(err), SCMP_SYS(unshare), 1, SCMP_A0(SCMP_CMP_MASKED_EQ, bit, bit));
        seccomp_rule_add(ctx, SCMP_ACT_ERRNO(err), SCMP_SYS(setns), 1, SCMP_A1(SCMP_CMP_MASKED_EQ, bit, bit));
    }
    seccomp_rule_add(ctx, SCMP_ACT_ERRNO(ENOSYS), SCMP_SYS(clone3), 0);
    /* setns with nstype 0 may enter any namespace: refused too */
    seccomp_rule_add(ctx, SCMP_ACT_ERRNO(err), SCMP_SYS(setns), 1, SCMP_A1(SCMP_CMP_EQ, 0, 0));
}

/* The calls systemd always allows under an allow list (systemd.exec(5)). */
static const char *const implicit[] = {"execve",    "exit",          "exit_group",   "getrlimit", "rt_sigreturn",
                                       "sigreturn", "clock_gettime", "gettimeofday", "nanosleep", "clock_nanosleep",
                                       "time"};

/* RestrictAddressFamilies=AF_X AF_Y... (an allow list, as the shipped
 * unit has): socket() of any other family is refused. Under a system-call
 * allow list socket() is allowed for those families alone (the others get
 * the list's error), since an unconditional allow would win over any
 * refusal; else the others are EAFNOSUPPORT, as systemd answers. */
static void restrict_families(scmp_filter_ctx ctx, char *value, int allow_list)
{
    static const struct {
        const char *name;
        int af;
    } fams[] = {{"AF_UNIX", AF_UNIX},
                {"AF_INET", AF_INET},
                {"AF_INET6", AF_INET6},
                {"AF_NETLINK", AF_NETLINK},
                {"AF_PACKET", AF_PACKET}};
    int allowed[8], n = 0;
    for (char *w = strtok(value, " \t"); w; w = strtok(NULL, " \t"))
        for (size_t i = 0; i < sizeof fams / sizeof *fams; i++)
            if (strcmp(w, fams[i].name) == 0 && n < 8)
                allowed[n++] = fams[i].af;
    for (int af = 0; af < 64; af++) {
        int ok = 0;
        for (int i = 0; i < n; i++)
            ok |= allowed[i] == af;
        if (allow_list && ok)
            seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(socket), 1, SCMP_A0(SCMP_CMP_EQ, af, 0));
        else if (!allow_list && !ok)
            seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EAFNOSUPPORT), SCMP_SYS(socket), 1, SCMP_A0(SCMP_CMP_EQ, af, 0));
    }
}

static char families[LINE];
static int protect_hostname;

static void install(const calls *c, unsigned long ns, int err)
{
    scmp_filter_ctx ctx = seccomp_init(c->mode == 1 ? SCMP_ACT_ERRNO((uint32_t)err) : SCMP_ACT_ALLOW);
    if (!ctx)
        die("seccomp_init failed");
    for (int i = 0; i < c->n; i++)
        if (c->allow[i] && !(families[0] && c->mode == 1 && strcmp(c->names[i], "socket") == 0))
            add_rule(ctx, c->mode == 1 ? SCMP_ACT_ALLOW : SCMP_ACT_ERRNO((uint32_t)err), c->names[i]);
    if (c->mode == 1)
        for (size_t i = 0; i < sizeof implicit / sizeof *implicit; i++)
            add_rule(ctx, SCMP_ACT_ALLOW, implicit[i]);
    if (ns)
        restrict_ns(ctx, ns, EPERM);
    if (families[0])
        restrict_families(ctx, families, c->mode == 1);
    if (protect_hostname) {
        add_rule(ctx, SCMP_ACT_ERRNO(EPERM), "sethostname");
        add_rule(ctx, SCMP_ACT_ERRNO(EPERM), "setdomainname");
    }
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 || seccomp_load(ctx) != 0)
        die("cannot install the filter");
    seccomp_release(ctx);
}

int main(int argc, char **argv)
{
    if (argc < 3)
        die("usage: unit-filter UNIT PROGRAM ARGS...");
    FILE *f = fopen(argv[1], "r");
    if (!f)
        die("cannot read the unit file");
    static calls c;
    static char line[LINE];
    unsigned long ns = 0;
    int err = EPERM;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = 0;
        if (strncmp(line, "SystemCallFilter=", 17) == 0)
            filter_line(&c, line + 17);
        else if (strncmp(line, "RestrictNamespaces=", 19) == 0)
            ns = ns_refused(line + 19);
        else if (strncmp(line, "RestrictAddressFamilies=", 24) == 0)
            snprintf(families, sizeof families, "%s", line + 24);
        else if (strncmp(line, "ProtectHostname=", 16) == 0)
            protect_hostname = strcmp(line + 16, "yes") == 0;
        else if (strncmp(line, "SystemCallErrorNumber=", 22) == 0)
            err = strcmp(line + 22, "EPERM") == 0 ? EPERM : strcmp(line + 22, "ENOSYS") == 0 ? ENOSYS : EPERM;
    }
    fclose(f);
    install(&c, ns, err);
    execvp(argv[2], argv + 2);
    perror("unit-filter: exec");
    return 127;
}
