/* The schema's migrations (deploy/sql/NNN_name.sql), built into the binary
 * by daemon/store/embed_sql.py: in order, numbered from 1 without gaps. */
#ifndef RD_STORE_MIGRATIONS_H
#define RD_STORE_MIGRATIONS_H

typedef struct {
    int version;
    const char *name;
    const char *sql; /* @BLOB@ stands for the engine's type of bytes */
} rd_store_migration;

extern const rd_store_migration rd_store_migrations[];
extern const int rd_store_migration_count;

#endif
