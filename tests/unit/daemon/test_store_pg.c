/* The job store on PostgreSQL: the cases of test_store.c against a server
 * the tests start (tests/support/pg_server.h: each test a database of its
 * own on one server, and a private server for the test that stops it), and what
 * only a server has: three daemons rendering one job, a server that goes
 * away and comes back under the same handle, LISTEN/NOTIFY, URL and
 * conninfo specs. A suite of its own, so that it runs alone with --filter. */
#include <arpa/inet.h>
#include <criterion/criterion.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "migrations.h"
#include "rayd/clock.h"
#include "store.h"
#include "support/pg_server.h"
#include "support/store_cases.h"

static pg_server g_pg;
static store_env g_env;

static void up(void)
{
    pg_server_shared(&g_pg);
    snprintf(g_env.spec, sizeof g_env.spec, "%s", g_pg.conninfo);
    g_env.opt = rd_store_options_default();
    g_env.events_named = 1;
}

static void down(void) { pg_server_destroy(&g_pg); }

TestSuite(store_pg, .init = up, .fini = down, .timeout = 90);

Test(store_pg, create_and_get) { case_create_get(&g_env); }

Test(store_pg, lifecycle_finish_fail_cancel) { case_lifecycle(&g_env); }

Test(store_pg, list_expire_delete) { case_list_expire_delete(&g_env); }

Test(store_pg, tiles_and_passes) { case_tiles_and_passes(&g_env); }

Test(store_pg, claim_takes_the_oldest_job_first) { case_claim_oldest_job_first(&g_env); }

Test(store_pg, lease_expiry_hands_tiles_to_others) { case_lease_expiry(&g_env); }

Test(store_pg, renew_and_release) { case_renew_and_release(&g_env); }

Test(store_pg, three_daemons_render_one_job) { case_concurrent_claims(&g_env, 3, 300, 2); }

Test(store_pg, durable_across_close_and_reopen) { case_durable_across_reopen(&g_env); }

Test(store_pg, committed_jobs_survive_sigkill) { case_survives_kill(&g_env); }

Test(store_pg, limits_and_bad_arguments) { case_limits_and_bad_arguments(&g_env); }

Test(store_pg, notify_wakes_a_waiting_handle) { case_wait_wakes(&g_env, 100); }

Test(store_pg, gated_passes_open_only_by_pass_open) { case_gated_passes(&g_env); }

Test(store_pg, gated_pass_open_refusals) { case_gated_refusals(&g_env); }

Test(store_pg, gated_schedule_round_trips_within_limits) { case_gated_schedule(&g_env); }

Test(store_pg, gated_pass_open_notifies_tiles) { case_gated_wait(&g_env); }

Test(store_pg, gated_pass_open_race_has_one_winner) { case_gated_race(&g_env, 4, 5); }

Test(store_pg, grade_round_trip_exact_doubles) { case_grade_round_trip(&g_env); }

/* A spec whose options override rayd's (and a server default of 0 would do
 * the same): doubles still come back bit for bit. */
Test(store_pg, grade_doubles_exact_whatever_extra_float_digits)
{
    snprintf(g_env.spec, sizeof g_env.spec, "%s options='-c extra_float_digits=0'", g_pg.conninfo);
    case_grade_round_trip(&g_env);
}

Test(store_pg, grade_error_row_has_no_metrics) { case_grade_error_row(&g_env); }

Test(store_pg, grade_diff_image_round_trip_and_absence) { case_grade_images(&g_env); }

Test(store_pg, grade_term_round_trip_and_image) { case_grade_term(&g_env); }

Test(store_pg, grades_list_filters_and_order) { case_grades_list(&g_env); }

Test(store_pg, batch_counts_to_done_once) { case_batch_progress(&g_env); }
Test(store_pg, batches_running_of_a_daemon_and_their_students) { case_batches_running(&g_env); }

Test(store_pg, batch_last_grades_race_counts_exactly_total) { case_batch_race(&g_env, 5); }

Test(store_pg, grades_expire_with_images_then_empty_batches) { case_grades_expire(&g_env); }

Test(store_pg, batches_list_newest_first_in_pages) { case_batches_list(&g_env); }

Test(store_pg, batch_delete_takes_its_grades_and_images) { case_batch_delete(&g_env); }

Test(store_pg, grades_delete_by_student_and_by_id) { case_grades_delete(&g_env); }

Test(store_pg, grade_limits_and_bad_arguments) { case_grade_limits(&g_env); }

static long long raw_int(const char *sql)
{
    PGconn *c = PQconnectdb(g_pg.conninfo);
    cr_assert_eq(PQstatus(c), CONNECTION_OK, "%s", PQerrorMessage(c));
    PGresult *r = PQexec(c, sql);
    cr_assert(PQresultStatus(r) == PGRES_TUPLES_OK || PQresultStatus(r) == PGRES_COMMAND_OK, "%s: %s", sql,
              PQerrorMessage(c));
    long long v = PQresultStatus(r) == PGRES_TUPLES_OK ? atoll(PQgetvalue(r, 0, 0)) : 0;
    PQclear(r);
    PQfinish(c);
    return v;
}

static void raw_exec(const char *sql) { raw_int(sql); }

Test(store_pg, a_version_2_store_upgrades_to_ungated_jobs) { case_upgrade_from_version_2(&g_env, raw_exec, "BYTEA"); }

Test(store_pg, a_version_3_store_upgrades_to_grades)
{
    case_upgrade_from_version_3(&g_env, raw_exec, "BYTEA");
    cr_assert_eq(raw_int("SELECT max(version) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int("SELECT count(*) FROM schema_version WHERE version = 4 AND name = '004_grades.sql'"), 1);
    cr_assert_eq(raw_int("SELECT count(*) FROM information_schema.columns WHERE table_name = 'grades' "
                         "AND column_name = 'psnr_db' AND data_type = 'double precision'"),
                 1, "an 8-byte float");
    cr_assert_eq(raw_int("SELECT count(*) FROM information_schema.columns "
                         "WHERE table_name = 'grade_images' AND column_name = 'data' AND data_type = 'bytea'"),
                 1);
}

Test(store_pg, url_and_conninfo_specs_and_idempotent_migrations)
{
    const char *specs[3] = {g_pg.url, g_pg.conninfo, NULL};
    char short_url[220];
    snprintf(short_url, sizeof short_url, "postgres://%s", g_pg.url + strlen("postgresql://"));
    specs[2] = short_url;
    for (int i = 0; i < 3; i++) {
        rd_error err = {0};
        rd_store *s = rd_store_open(specs[i], NULL, &err);
        cr_assert(s, "%s: %s", specs[i], err.message);
        cr_assert_str_eq(rd_store_engine_name(s), "postgresql");
        if (i == 0)
            store_put_job(s, "kept", 1, 0, 0);
        rd_store_close(s);
    }
    cr_assert_eq(raw_int("SELECT count(*) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int("SELECT max(version) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int("SELECT count(*) FROM jobs"), 1);
    cr_assert_eq(raw_int("SELECT count(*) FROM information_schema.columns "
                         "WHERE table_name = 'jobs' AND column_name = 'scene' AND data_type = 'bytea'"),
                 1, "@BLOB@ is BYTEA here");
    raw_int("INSERT INTO schema_version VALUES (99, '099_future.sql', 0)");
    rd_error err = {0};
    cr_assert_null(rd_store_open(g_pg.url, NULL, &err));
    cr_assert_eq(err.code, RD_ERR_UNSUPPORTED, "%s", err.message);
}

/* A port on 127.0.0.1 that refuses connections while the socket is held:
 * bound, not listening. */
Test(store_pg, an_unreachable_server_fails_fast_at_open)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t len = sizeof a;
    cr_assert(bind(fd, (struct sockaddr *)&a, sizeof a) == 0 && getsockname(fd, (struct sockaddr *)&a, &len) == 0);
    char spec[128];
    snprintf(spec, sizeof spec, "postgresql://postgres@127.0.0.1:%d/rayd_test", ntohs(a.sin_port));
    rd_error err = {0};
    double t0 = rd_now_ms();
    cr_assert_null(rd_store_open(spec, NULL, &err));
    cr_assert_eq(err.code, RD_ERR_UNAVAILABLE, "%s", err.message);
    cr_assert_lt(rd_now_ms() - t0, 3000.0);
    close(fd);
}

/* Every call on a handle whose server is down: RD_ERR_UNAVAILABLE, quickly. */
static void assert_down(rd_store *s, const rd_store_tile *held)
{
    rd_store_job_info in;
    rd_store_tile t[4];
    int n;
    rd_store_job_brief *l;
    size_t ln;
    rd_store_job_spec j = {.id = "during", .scene = "x", .scene_len = 1, .format = "cfg", .submitted_ms = 5};
    for (int call = 0; call < 6; call++) {
        rd_error err = {0};
        double t0 = rd_now_ms();
        rd_error_code c = call == 0   ? rd_store_ping(s, &err)
                          : call == 1 ? rd_store_job_get(s, "kept", &in, &err)
                          : call == 2 ? rd_store_job_create(s, &j, &err)
                          : call == 3 ? rd_store_claim(s, "d1", 4, 60000, t, &n, &err)
                          : call == 4 ? rd_store_tile_done(s, "d1", held, "r1", 2, NULL, &err)
                                      : rd_store_jobs_list(s, ~0u, 10, &l, &ln, &err);
        double ms = rd_now_ms() - t0;
        cr_assert_eq(c, RD_ERR_UNAVAILABLE, "call %d with the server down: %s (%s)", call, rd_error_name(c),
                     err.message);
        cr_assert_lt(ms, 1500.0, "call %d took %.0f ms", call, ms);
    }
    rd_store_event ev;
    rd_error err = {0};
    double t0 = rd_now_ms();
    cr_assert_eq(rd_store_wait(s, 300, &ev, &err), RD_ERR_UNAVAILABLE);
    cr_assert(rd_now_ms() - t0 >= 290 && rd_now_ms() - t0 < 1800, "a failing wait sleeps out its timeout");
}

Test(store_pg, a_server_restart_fails_fast_then_the_same_handle_recovers)
{
    pg_server_start(&g_pg);
    snprintf(g_env.spec, sizeof g_env.spec, "%s", g_pg.conninfo);
    rd_store *s = store_env_open(&g_env);
    store_put_job(s, "kept", 1, 4, 1);
    rd_store_tile t[2];
    int n = 0;
    rd_error err = {0};
    cr_assert_eq(rd_store_claim(s, "d1", 2, 60000, t, &n, &err), RD_OK, "%s", err.message);
    cr_assert_eq(n, 2);
    cr_assert_eq(rd_store_tile_done(s, "d1", &t[0], "r0", 2, NULL, &err), RD_OK, "%s", err.message);
    pg_server_stop(&g_pg);
    assert_down(s, &t[1]);
    sleep_ms_store(2000);
    cr_assert_eq(rd_store_ping(s, &err), RD_ERR_UNAVAILABLE, "still down");
    pg_server_restart(&g_pg);
    cr_assert_eq(rd_store_ping(s, &err), RD_OK, "the same handle reconnects: %s", err.message);
    rd_store_job_info in;
    cr_assert_eq(rd_store_job_get(s, "kept", &in, &err), RD_OK, "%s", err.message);
    cr_assert(in.status == RD_STORE_RUNNING && in.tiles_done == 1, "committed rows are kept");
    rd_store_job_info_free(&in);
    cr_assert_eq(rd_store_tile_done(s, "d1", &t[1], "r1", 2, NULL, &err), RD_OK, "the lease held: %s", err.message);
    rd_store_tile_data *td;
    size_t tn;
    cr_assert_eq(rd_store_tiles_get(s, "kept", &td, &tn, &err), RD_OK);
    cr_assert(tn == 2 && memcmp(td[0].data, "r0", 2) == 0 && memcmp(td[1].data, "r1", 2) == 0);
    rd_store_tiles_free(td, tn);
    /* It listens again: another handle's submission wakes it. */
    rd_store *b = store_env_open(&g_env);
    store_put_job(b, "after", 2, 0, 0);
    rd_store_event ev;
    cr_assert_eq(rd_store_wait(s, 2000, &ev, &err), RD_OK);
    cr_assert(ev.kind == RD_STORE_EV_SUBMITTED && strcmp(ev.job_id, "after") == 0);
    rd_store_close(b);
    rd_store_close(s);
}

/* A handle that never waits keeps the newest 64 events, not all of them. */
Test(store_pg, events_kept_are_bounded_and_newest)
{
    rd_store *a = store_env_open(&g_env), *b = store_env_open(&g_env);
    char id[16];
    for (int i = 0; i < 100; i++) {
        snprintf(id, sizeof id, "n%02d", i);
        store_put_job(b, id, i, 0, 0);
    }
    rd_error err = {0};
    rd_store_event ev, last = {0};
    int n = 0;
    for (double t0 = rd_now_ms(); n < 100 && rd_now_ms() - t0 < 2000;) {
        cr_assert_eq(rd_store_ping(a, &err), RD_OK, "%s", err.message);
        cr_assert_eq(rd_store_wait(a, 0, &ev, &err), RD_OK);
        if (ev.kind == RD_STORE_EV_NONE && last.kind != RD_STORE_EV_NONE && strcmp(last.job_id, "n99") == 0)
            break;
        if (ev.kind != RD_STORE_EV_NONE) {
            last = ev;
            n++;
        }
    }
    cr_assert(n >= 1 && n <= 64, "%d events kept", n);
    cr_assert_str_eq(last.job_id, "n99", "the newest is kept");
    rd_store_close(a);
    rd_store_close(b);
}

/* A job whose insert fails with the server's SQLSTATE (raised by a trigger,
 * as the server raises them on a full disk or a corrupt page). */
static rd_error_code create_fails_with(rd_store *s, const char *sqlstate, const char *id, rd_error *err)
{
    char sql[400];
    snprintf(sql, sizeof sql,
             "CREATE OR REPLACE FUNCTION rayd_fault() RETURNS trigger LANGUAGE plpgsql AS $$ BEGIN "
             "RAISE EXCEPTION 'injected fault' USING ERRCODE = '%s'; END $$",
             sqlstate);
    raw_exec(sql);
    raw_exec("CREATE TRIGGER rayd_fault BEFORE INSERT ON jobs FOR EACH ROW EXECUTE FUNCTION rayd_fault()");
    rd_store_job_spec spec = {.id = id, .scene = "x", .scene_len = 1, .format = "cfg", .submitted_ms = 1};
    rd_error_code c = rd_store_job_create(s, &spec, err);
    raw_exec("DROP TRIGGER rayd_fault ON jobs");
    return c;
}

/* disk_full (53100) is RD_ERR_NOSPACE, the next write may go through;
 * data_corrupted (XX001) and index_corrupted (XX002) are RD_ERR_DAMAGED,
 * saying so. */
Test(store_pg, a_full_disk_and_a_damaged_page_are_said)
{
    rd_error err = {0};
    rd_store *s = rd_store_open(g_pg.conninfo, NULL, &err);
    cr_assert(s, "%s", err.message);
    cr_assert_eq(create_fails_with(s, "53100", "full", &err), RD_ERR_NOSPACE, "%s", err.message);
    cr_assert(strstr(err.message, "no space left"), "%s", err.message);
    rd_store_job_spec spec = {.id = "after", .scene = "x", .scene_len = 1, .format = "cfg", .submitted_ms = 2};
    cr_assert_eq(rd_store_job_create(s, &spec, &err), RD_OK, "%s", err.message);
    cr_assert_eq(rd_store_ping(s, &err), RD_OK, "%s", err.message);
    const char *damaged[] = {"XX001", "XX002"};
    for (int i = 0; i < 2; i++) {
        cr_assert_eq(create_fails_with(s, damaged[i], "damaged", &err), RD_ERR_DAMAGED, "%s: %s", damaged[i],
                     err.message);
        cr_assert(strstr(err.message, "damaged"), "%s", err.message);
    }
    rd_store_close(s);
}
