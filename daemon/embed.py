#!/usr/bin/python3
"""Files as C string constants, for what the binary carries (the web page,
the OpenAPI document, the store's migrations).

    embed.py IN NAME > OUT.c    one file as `const char NAME[]`

Other generators import c_string()."""
import sys


def c_string(data, indent="    "):
    """The bytes as the lines of a C string literal (no trigraphs, any byte)."""
    out, line = [], ""
    for b in data:
        c = chr(b)
        if c == "\\":
            line += "\\\\"
        elif c == '"':
            line += '\\"'
        elif c == "?":
            line += "\\?"  # no trigraphs
        elif c == "\n":
            out.append('%s"%s\\n"' % (indent, line))
            line = ""
        elif 32 <= b < 127:
            line += c
        else:
            line += "\\%03o" % b
    if line or not out:
        out.append('%s"%s"' % (indent, line))
    return "\n".join(out)


if __name__ == "__main__":
    data = open(sys.argv[1], "rb").read()
    print("/* Generated from %s by daemon/embed.py; do not edit. */" % sys.argv[1])
    print("const char %s[] =\n%s;" % (sys.argv[2], c_string(data)))
