#!/bin/sh
# Writes help2man's include file for rayd(1): every command's --help as a
# section of its own, so the man page says what --help says.
# Usage: docs/man/commands.sh RAYD > FILE.h2m
set -eu
rayd=$1
cat "$(dirname "$0")/rayd.h2m"
echo "[COMMANDS]"
# "grade --code" has a --help of its own (the code grader's options).
for cmd in render serve grade "grade --code" converge convert compare limits schema; do
    printf '.SS "rayd %s"\n.nf\n' "$cmd"
    # shellcheck disable=SC2086
    if [ "$cmd" = limits ]; then "$rayd" limits; elif [ "$cmd" = schema ]; then echo "rayd schema prints the JSON Schema of JSON scenes."; else "$rayd" $cmd --help; fi |
        sed -e 's/\\/\\e/g' -e 's/^\./\\\&./' -e "s/^'/\\\\\\&'/"
    printf '.fi\n'
done
