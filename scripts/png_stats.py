#!/usr/bin/env python3
"""Pixel statistics of PNG files, with the standard library only (zlib): for the Blender render
test, which checks that rendered frames are not blank.

    scripts/png_stats.py FILE.png...

Prints one line per file:
    FILE width=W height=H channels=C min=.. max=.. mean=.. std=.. distinct=..
over the colour channels (alpha left out), values scaled to 0..255. Exit status 0 when every file
decodes, 2 when one does not (missing, not a PNG, interlaced, or a palette image: Blender writes
none of these). Handles 8- and 16-bit grey, grey+alpha, RGB and RGBA, all five row filters.
"""
import math
import struct
import sys
import zlib

CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type -> samples per pixel


def unfilter(data, height, stride, bpp):
    """Undoes the per-row PNG filters (RFC 2083 section 6); returns the raw rows."""
    rows = []
    prev = bytearray(stride)
    pos = 0
    for _ in range(height):
        ftype = data[pos]
        row = bytearray(data[pos + 1:pos + 1 + stride])
        pos += 1 + stride
        if ftype == 1:
            for i in range(bpp, stride):
                row[i] = (row[i] + row[i - bpp]) & 0xFF
        elif ftype == 2:
            for i in range(stride):
                row[i] = (row[i] + prev[i]) & 0xFF
        elif ftype == 3:
            for i in range(stride):
                left = row[i - bpp] if i >= bpp else 0
                row[i] = (row[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif ftype == 4:
            for i in range(stride):
                a = row[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if (pa <= pb and pa <= pc) else (b if pb <= pc else c)
                row[i] = (row[i] + pred) & 0xFF
        elif ftype != 0:
            raise ValueError("bad filter type %d" % ftype)
        rows.append(row)
        prev = row
    return rows


def stats(path):
    with open(path, "rb") as f:
        blob = f.read()
    if blob[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG file")
    pos, idat, header = 8, [], None
    while pos + 8 <= len(blob):
        length, kind = struct.unpack(">I4s", blob[pos:pos + 8])
        body = blob[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None:
        raise ValueError("no IHDR chunk")
    width, height, depth, ctype, _, _, interlace = header
    if ctype not in CHANNELS or depth not in (8, 16) or interlace:
        raise ValueError("unsupported PNG (colour type %d, depth %d, interlace %d)" % (ctype, depth, interlace))
    channels = CHANNELS[ctype]
    sample_bytes = depth // 8
    bpp = channels * sample_bytes
    rows = unfilter(zlib.decompress(b"".join(idat)), height, width * bpp, bpp)
    colour = channels - 1 if ctype in (4, 6) else channels  # leave alpha out
    scale = 255.0 / 65535.0 if depth == 16 else 1.0
    lo, hi, total, total2, n = 1e9, -1e9, 0.0, 0.0, 0
    distinct = set()
    for row in rows:
        for x in range(width):
            base = x * bpp
            pixel = []
            for c in range(colour):
                o = base + c * sample_bytes
                v = (row[o] << 8 | row[o + 1]) * scale if depth == 16 else row[o]
                pixel.append(v)
                lo, hi = min(lo, v), max(hi, v)
                total += v
                total2 += v * v
                n += 1
            if len(distinct) < 100000:
                distinct.add(tuple(pixel))
    mean = total / n
    std = math.sqrt(max(0.0, total2 / n - mean * mean))
    return "width=%d height=%d channels=%d min=%.6g max=%.6g mean=%.6g std=%.6g distinct=%d" % (
        width, height, channels, lo, hi, mean, std, len(distinct))


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    status = 0
    for path in argv[1:]:
        try:
            print("%s %s" % (path, stats(path)))
        except (OSError, ValueError, zlib.error, struct.error) as e:
            print("%s: %s" % (path, e), file=sys.stderr)
            status = 2
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv))
