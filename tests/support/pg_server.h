/* PostgreSQL servers for tests: initdb into a new temporary folder, pg_ctl
 * start listening on 127.0.0.1 only, on a port picked here (its socket in
 * that folder, not the system's); stopped with pg_ctl and, failing that, by
 * its pid. A test either shares one server with the other tests of the run
 * (a database of its own on it: starting a server costs a second and a
 * half) or has a private one (to stop and start it).
 *
 * Tests run as root here, and initdb refuses root: as root, the folder is
 * given to the postgres user (Debian's postgresql package makes it) and the
 * server's commands run as that user through runuser. A guard process
 * stops a private server and removes its folder if the test process dies
 * first, and the shared one once the test runner (the tests' parent) has
 * exited.
 * Missing binaries (not the package postgresql, deploy/deps.sh), a missing
 * postgres user or a server that does not start fail the test with the
 * reason and the server's log: such a test is never skipped. */
#ifndef RD_TEST_PG_SERVER_H
#define RD_TEST_PG_SERVER_H

#include <sys/types.h>

typedef struct {
    char dir[64];       /* the temporary folder: data/, server.log, the socket */
    char bin[256];      /* the folder of initdb and pg_ctl */
    int port;           /* on 127.0.0.1 */
    pid_t pid;          /* the postmaster's while it runs, else 0 */
    pid_t guard;        /* the guard process */
    int guard_fd;       /* its pipe: closing it ends the guard */
    char conninfo[200]; /* host=127.0.0.1 port=P dbname=rayd_test user=postgres */
    char url[200];      /* postgresql://postgres@127.0.0.1:P/rayd_test */
    int shared;         /* the run's shared server: not to be stopped */
} pg_server;

/* A private server: initdb, start, CREATE DATABASE rayd_test; asserts
 * every step. */
void pg_server_start(pg_server *s);

/* The run's shared server (started by the first test that asks, under a
 * lock) and a new database on it for this test, named in conninfo and url.
 * pg_server_destroy leaves the server running. */
void pg_server_shared(pg_server *s);

/* Stops the server (fast shutdown: sessions are ended), keeping its data. */
void pg_server_stop(pg_server *s);

/* Starts it again on the same port with the same data. */
void pg_server_restart(pg_server *s);

/* Stops it if it runs and removes the folder. */
void pg_server_destroy(pg_server *s);

#endif
