/* The job store on SQLite (daemon/store/): every operation, durability
 * across a reopen and a SIGKILL, concurrent claims from separate handles on
 * one file, lease expiry, migrations, limits. The same cases run on
 * PostgreSQL in test_store_pg.c. */
#include <criterion/criterion.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "migrations.h"
#include "store.h"
#include "support/store_cases.h"

static char g_dir[64];
static store_env g_env;

static void up(void)
{
    snprintf(g_dir, sizeof g_dir, "/tmp/rayd-store.XXXXXX");
    cr_assert(mkdtemp(g_dir));
    /* A folder that does not exist yet, two levels down. */
    snprintf(g_env.spec, sizeof g_env.spec, "%s/var/store", g_dir);
    g_env.opt = rd_store_options_default();
    g_env.events_named = 0;
}

static void down(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    cr_expect_eq(system(cmd), 0);
}

TestSuite(store, .init = up, .fini = down, .timeout = 60);

Test(store, create_and_get) { case_create_get(&g_env); }

Test(store, lifecycle_finish_fail_cancel) { case_lifecycle(&g_env); }

Test(store, list_expire_delete) { case_list_expire_delete(&g_env); }

Test(store, tiles_and_passes) { case_tiles_and_passes(&g_env); }

Test(store, claim_takes_the_oldest_job_first) { case_claim_oldest_job_first(&g_env); }

Test(store, lease_expiry_hands_tiles_to_others) { case_lease_expiry(&g_env); }

Test(store, renew_and_release) { case_renew_and_release(&g_env); }

Test(store, concurrent_handles_never_share_a_tile) { case_concurrent_claims(&g_env, 4, 200, 2); }

Test(store, durable_across_close_and_reopen) { case_durable_across_reopen(&g_env); }

Test(store, committed_jobs_survive_sigkill) { case_survives_kill(&g_env); }

Test(store, limits_and_bad_arguments) { case_limits_and_bad_arguments(&g_env); }

Test(store, wait_wakes_on_another_handles_commit) { case_wait_wakes(&g_env, 100); }

Test(store, gated_passes_open_only_by_pass_open) { case_gated_passes(&g_env); }

Test(store, gated_pass_open_refusals) { case_gated_refusals(&g_env); }

Test(store, gated_schedule_round_trips_within_limits) { case_gated_schedule(&g_env); }

Test(store, gated_pass_open_wakes_a_waiting_handle) { case_gated_wait(&g_env); }

Test(store, gated_pass_open_race_has_one_winner) { case_gated_race(&g_env, 4, 5); }

Test(store, grade_round_trip_exact_doubles) { case_grade_round_trip(&g_env); }

Test(store, grade_error_row_has_no_metrics) { case_grade_error_row(&g_env); }

Test(store, grade_diff_image_round_trip_and_absence) { case_grade_images(&g_env); }

Test(store, grade_term_round_trip_and_image) { case_grade_term(&g_env); }

Test(store, grades_list_filters_and_order) { case_grades_list(&g_env); }

Test(store, batch_counts_to_done_once) { case_batch_progress(&g_env); }
Test(store, batches_running_of_a_daemon_and_their_students) { case_batches_running(&g_env); }

Test(store, batch_last_grades_race_counts_exactly_total) { case_batch_race(&g_env, 5); }

Test(store, grades_expire_with_images_then_empty_batches) { case_grades_expire(&g_env); }

Test(store, batches_list_newest_first_in_pages) { case_batches_list(&g_env); }

Test(store, batch_delete_takes_its_grades_and_images) { case_batch_delete(&g_env); }

Test(store, grades_delete_by_student_and_by_id) { case_grades_delete(&g_env); }

Test(store, grade_limits_and_bad_arguments) { case_grade_limits(&g_env); }

static sqlite3 *raw_db(void)
{
    char path[300];
    snprintf(path, sizeof path, "%s/rayd.sqlite3", g_env.spec);
    sqlite3 *db = NULL;
    cr_assert_eq(sqlite3_open_v2(path, &db, SQLITE_OPEN_READWRITE, NULL), SQLITE_OK, "%s", path);
    return db;
}

static long long raw_int(sqlite3 *db, const char *sql)
{
    sqlite3_stmt *st;
    cr_assert_eq(sqlite3_prepare_v2(db, sql, -1, &st, NULL), SQLITE_OK, "%s: %s", sql, sqlite3_errmsg(db));
    cr_assert_eq(sqlite3_step(st), SQLITE_ROW);
    long long v = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    return v;
}

/* SQL on the store's file through SQLite itself, before rayd made it. */
static void raw_exec(const char *sql)
{
    char cmd[300], path[300];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", g_env.spec);
    cr_assert_eq(system(cmd), 0);
    snprintf(path, sizeof path, "%s/rayd.sqlite3", g_env.spec);
    sqlite3 *db = NULL;
    cr_assert_eq(sqlite3_open_v2(path, &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, NULL), SQLITE_OK, "%s", path);
    char *msg = NULL;
    cr_assert_eq(sqlite3_exec(db, sql, NULL, NULL, &msg), SQLITE_OK, "%s: %s", sql, msg ? msg : "");
    sqlite3_close(db);
}

Test(store, a_version_2_store_upgrades_to_ungated_jobs) { case_upgrade_from_version_2(&g_env, raw_exec, "BLOB"); }

Test(store, a_version_3_store_upgrades_to_grades)
{
    case_upgrade_from_version_3(&g_env, raw_exec, "BLOB");
    sqlite3 *db = raw_db();
    cr_assert_eq(raw_int(db, "SELECT max(version) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int(db, "SELECT count(*) FROM schema_version WHERE version = 4 AND name = '004_grades.sql'"), 1);
    cr_assert_eq(raw_int(db, "SELECT count(*) FROM grades WHERE failed_fraction IS NOT NULL"), 1);
    sqlite3_close(db);
}

Test(store, migrations_once_and_idempotent)
{
    rd_store *s = store_env_open(&g_env);
    store_put_job(s, "kept", 1, 0, 0);
    rd_store_close(s);
    s = store_env_open(&g_env);
    rd_store_close(s);
    sqlite3 *db = raw_db();
    cr_assert_eq(raw_int(db, "SELECT count(*) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int(db, "SELECT max(version) FROM schema_version"), rd_store_migration_count);
    cr_assert_eq(raw_int(db, "SELECT count(*) FROM jobs"), 1, "reopening kept the data");
    cr_assert_eq(raw_int(db, "SELECT count(*) FROM sqlite_master WHERE name = 'tiles'"), 1);
    sqlite3_stmt *st;
    cr_assert_eq(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &st, NULL), SQLITE_OK);
    cr_assert_eq(sqlite3_step(st), SQLITE_ROW);
    cr_assert_str_eq((const char *)sqlite3_column_text(st, 0), "wal");
    sqlite3_finalize(st);
    sqlite3_close(db);
}

Test(store, a_newer_schema_is_refused)
{
    rd_store_close(store_env_open(&g_env));
    sqlite3 *db = raw_db();
    cr_assert_eq(sqlite3_exec(db, "INSERT INTO schema_version VALUES (99, '099_future.sql', 0)", NULL, NULL, NULL),
                 SQLITE_OK);
    sqlite3_close(db);
    rd_error err = {0};
    cr_assert_null(rd_store_open(g_env.spec, NULL, &err));
    cr_assert_eq(err.code, RD_ERR_UNSUPPORTED, "%s", err.message);
    cr_assert(strstr(err.message, "99"), "%s", err.message);
}

Test(store, open_errors_and_specs)
{
    char file[128];
    snprintf(file, sizeof file, "%s/plain-file", g_dir);
    FILE *f = fopen(file, "w");
    cr_assert(f);
    fclose(f);
    rd_error err = {0};
    cr_assert_null(rd_store_open(file, NULL, &err));
    cr_assert_eq(err.code, RD_ERR_IO, "a file is not a folder: %s", err.message);
    /* An absolute folder with = in its name is a folder, not a conninfo. */
    snprintf(g_env.spec, sizeof g_env.spec, "%s/key=value", g_dir);
    rd_store *s = store_env_open(&g_env);
    cr_assert_str_eq(rd_store_engine_name(s), "sqlite");
    rd_store_close(s);
    struct stat sb;
    char db[300];
    snprintf(db, sizeof db, "%s/rayd.sqlite3", g_env.spec);
    cr_assert_eq(stat(db, &sb), 0, "the store is %s", db);
    rd_store_options o = rd_store_options_default();
    o.timeout_ms = 0;
    cr_assert_null(rd_store_open(g_env.spec, &o, &err));
    cr_assert_eq(err.code, RD_ERR_INVALID);
}

Test(store, synchronous_normal_is_as_correct)
{
    g_env.opt.sync_full = 0;
    case_durable_across_reopen(&g_env);
}
