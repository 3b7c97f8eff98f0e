#!/usr/bin/python3
"""Turns a file into a C string constant: embed.py IN NAME > OUT.c"""
import sys

data = open(sys.argv[1], "rb").read()
name = sys.argv[2]
out = ["/* Generated from %s by daemon/http/web/embed.py; do not edit. */" % sys.argv[1],
       "const char %s[] =" % name]
line = ""
for b in data:
    c = chr(b)
    if c == "\\":
        line += "\\\\"
    elif c == '"':
        line += '\\"'
    elif c == "?":
        line += "\\?"  # no trigraphs
    elif c == "\n":
        line += "\\n"
        out.append('    "%s"' % line)
        line = ""
    elif 32 <= b < 127:
        line += c
    else:
        line += "\\%03o" % b
if line:
    out.append('    "%s"' % line)
out[-1] += ";"
print("\n".join(out))
