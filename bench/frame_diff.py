#!/usr/bin/env python3
"""Compares two frame dumps of bench_view_split (SG_SPLIT_DUMP=FILE):
float32 RGB, width x height a frame, frames one after the other; OLD is
the reference. Prints how many channel values differ, the max abs and
max relative (|a-b| / max(|b|, 1e-6)) difference, and relMSE as
src/metrics/image_metrics.h defines it (epsilon = 1e-2 m^2, m the
reference frame's mean), per frame: the mean and the largest.

usage: frame_diff.py OLD.f32 NEW.f32 WIDTH HEIGHT"""
import sys
from array import array


def load(path):
    a = array("f")
    with open(path, "rb") as f:
        a.frombytes(f.read())
    return a


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    b, a = load(sys.argv[1]), load(sys.argv[2])
    n = int(sys.argv[3]) * int(sys.argv[4]) * 3
    if len(a) != len(b) or len(a) % n:
        sys.exit("sizes differ or are not whole frames: %d and %d values" % (len(b), len(a)))
    differ, max_abs, max_rel, rels = 0, 0.0, 0.0, []
    for f in range(len(a) // n):
        fa, fb = a[f * n:(f + 1) * n], b[f * n:(f + 1) * n]
        m = sum(fb) / n
        eps = 1e-2 * m * m if m != 0 else 1e-2
        r = 0.0
        for x, y in zip(fa, fb):
            if x == y:
                continue
            differ += 1
            d = abs(x - y)
            max_abs = max(max_abs, d)
            max_rel = max(max_rel, d / max(abs(y), 1e-6))
            r += d * d / (y * y + eps)
        rels.append(r / n)
    print("%d frames: %d of %d channel values differ; max abs difference %.3g; max relative %.3g; "
          "relMSE mean %.3g, largest %.3g" % (len(rels), differ, len(a), max_abs, max_rel,
                                               sum(rels) / len(rels), max(rels)))


main()
