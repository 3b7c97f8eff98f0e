#!/usr/bin/python3
"""Builds the store's migrations into C: embed_sql.py NNN_name.sql ... > OUT.c

Each file's number is its schema version; they must run 1, 2, 3... without
gaps, so a missing or misnumbered file stops the build."""
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from embed import c_string  # noqa: E402

files = sorted(sys.argv[1:], key=os.path.basename)
rows = []
for i, path in enumerate(files, 1):
    name = os.path.basename(path)
    m = re.match(r"^(\d{3})_[a-z0-9_]+\.sql$", name)
    if not m or int(m.group(1)) != i:
        sys.exit("embed_sql.py: %s should be numbered %03d_NAME.sql" % (name, i))
    rows.append("    {%d, \"%s\",\n%s},\n" % (i, name, c_string(open(path, "rb").read(), "        ")))
print("/* Generated from deploy/sql/ by daemon/store/embed_sql.py; do not edit. */")
print('#include "migrations.h"\n')
print("const rd_store_migration rd_store_migrations[] = {\n%s};" % "".join(rows))
print("const int rd_store_migration_count = %d;" % len(rows))
