#!/usr/bin/python3
"""pngdiff.py: how many pixels of two PNG images differ, for bench/run.sh.

usage: pngdiff.py [--rmse] A.png B.png

Prints one line:
    pixels=N differ=D over1=M max=K
N pixels in each image, D pixels that differ in any channel, M of them by more
than 1/255 in some channel, K the largest difference of any channel (0..255).
With --rmse it prints instead
    rmse=E mean_a=MA mean_b=MB pixels=N
E the root-mean-square difference over every pixel and channel, and MA, MB
the mean of each image's values, all in output units where 1 = 255 levels
(the units of rayd's error_estimate and of `rayd converge`).
Exit status 0 when compared (whatever the result), 2 when an image cannot be
read or the sizes differ.

Python's standard library only (zlib): 8-bit greyscale, grey+alpha, RGB, RGBA
and palette images, not interlaced, which is what rayd and POV-Ray write.
Alpha is ignored; pixels are compared as RGB.
"""
import struct
import sys
import zlib


def read_png(path):
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("%s: not a PNG file" % path)
    pos = 8
    idat = []
    plte = None
    w = h = depth = ctype = interlace = None
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            plte = body
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    if w is None:
        raise ValueError("%s: no IHDR" % path)
    if depth != 8 or interlace != 0 or ctype not in (0, 2, 3, 4, 6):
        raise ValueError("%s: only 8-bit non-interlaced PNGs are supported (depth %s, colour type %s, "
                         "interlace %s)" % (path, depth, ctype, interlace))
    bpp = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[ctype]
    raw = zlib.decompress(b"".join(idat))
    stride = w * bpp
    if len(raw) < h * (stride + 1):
        raise ValueError("%s: image data too short" % path)
    rows = []
    prev = bytearray(stride)
    for y in range(h):
        ft = raw[y * (stride + 1)]
        cur = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if ft == 0:
            pass
        elif ft == 1:
            for i in range(bpp, stride):
                cur[i] = (cur[i] + cur[i - bpp]) & 255
        elif ft == 2:
            cur = bytearray((a + b) & 255 for a, b in zip(cur, prev))
        elif ft == 3:
            for i in range(stride):
                left = cur[i - bpp] if i >= bpp else 0
                cur[i] = (cur[i] + ((left + prev[i]) >> 1)) & 255
        elif ft == 4:
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if (pa <= pb and pa <= pc) else (b if pb <= pc else c)
                cur[i] = (cur[i] + pr) & 255
        else:
            raise ValueError("%s: bad filter type %d in row %d" % (path, ft, y))
        rows.append(bytes(cur))
        prev = cur
    # To RGB rows.
    if ctype == 2:
        out = rows
    elif ctype == 6:
        out = [bytes(b for i, b in enumerate(r) if i % 4 != 3) for r in rows]
    elif ctype == 0:
        out = [bytes(v for v in r for _ in range(3)) for r in rows]
    elif ctype == 4:
        out = [bytes(r[i] for i in range(0, len(r), 2) for _ in range(3)) for r in rows]
    else:
        if plte is None:
            raise ValueError("%s: palette image without PLTE" % path)
        out = [b"".join(plte[3 * v:3 * v + 3] for v in r) for r in rows]
    return w, h, out


def rmse(wa, ha, a, b):
    """Root-mean-square difference and both means, 1 = 255 levels."""
    sq = sa = sb = 0
    for ra, rb in zip(a, b):
        sa += sum(ra)
        sb += sum(rb)
        if ra != rb:
            sq += sum((x - y) * (x - y) for x, y in zip(ra, rb))
    n = 3 * wa * ha
    return (sq / n) ** 0.5 / 255.0, sa / n / 255.0, sb / n / 255.0


def main(argv):
    want_rmse = len(argv) == 4 and argv[1] == "--rmse"
    if want_rmse:
        argv = argv[:1] + argv[2:]
    if len(argv) != 3:
        print("usage: pngdiff.py [--rmse] A.png B.png", file=sys.stderr)
        return 2
    try:
        wa, ha, a = read_png(argv[1])
        wb, hb, b = read_png(argv[2])
    except (OSError, ValueError, zlib.error) as e:
        print("pngdiff: %s" % e, file=sys.stderr)
        return 2
    if (wa, ha) != (wb, hb):
        print("pngdiff: sizes differ: %dx%d and %dx%d" % (wa, ha, wb, hb), file=sys.stderr)
        return 2
    if want_rmse:
        e, ma, mb = rmse(wa, ha, a, b)
        print("rmse=%.6f mean_a=%.6f mean_b=%.6f pixels=%d" % (e, ma, mb, wa * ha))
        return 0
    differ = over1 = mx = 0
    for ra, rb in zip(a, b):
        if ra == rb:
            continue
        for x in range(0, 3 * wa, 3):
            if ra[x:x + 3] != rb[x:x + 3]:
                d = max(abs(ra[x] - rb[x]), abs(ra[x + 1] - rb[x + 1]), abs(ra[x + 2] - rb[x + 2]))
                differ += 1
                if d > 1:
                    over1 += 1
                if d > mx:
                    mx = d
    print("pixels=%d differ=%d over1=%d max=%d" % (wa * ha, differ, over1, mx))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
