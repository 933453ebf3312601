#!/usr/bin/env python3
# Writes the hand-made seed inputs of fuzz/corpus/<harness>/seed-*: small, readable scenarios encoded the way
# fuzz/fuzz_input.hpp reads them (front to back; zero bytes and a used-up input decode to the defaults).
# The other inputs next to them are findings of earlier runs, kept as they were found: regression-* reproduce
# library bugs that were fixed (each has a test in tests/test_extremes.cpp), overflow-* an input outside the
# domain that made a harness invariant precise (docs/EXTREMES.md, "Outside the domain").
#
#   python3 fuzz/seeds.py        (rewrites fuzz/corpus/*/seed-*; deterministic)
import os
import random
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

# Indices into aaf_fuzz::reader::special()'s table.
ZERO, NEG_ZERO, NAN, INF, NEG_INF, DENORM, NEG_DENORM, MIN, NEG_MIN, MAX, NEG_MAX, ONE, NEG_ONE, EPS, BIG, TINY, NEG_BIG, HALF = range(18)


class Enc:
    def __init__(self, dbl=False):
        self.b = bytearray()
        self.dbl = dbl

    def byte(self, v):
        self.b.append(v & 0xFF)
        return self

    def flag(self, v):
        return self.byte(1 if v else 0)

    def u32(self, v):
        self.b += struct.pack("<I", v & 0xFFFFFFFF)
        return self

    # reader::value(): tag % 5
    def default(self):
        return self.byte(0)

    def bits(self, x):
        self.byte(1)
        self.b += struct.pack("<d" if self.dbl else "<f", x)
        return self

    def special(self, i):
        return self.byte(2).byte(i)

    def scaled(self, k):  # default * 2^k
        return self.byte(3).byte(k & 0xFF)

    def near(self, j):  # default * (1 + j/64)
        return self.byte(4).byte(j & 0xFF)

    # reader::count(): tag % 3
    def count_default(self):
        return self.byte(0)

    def count_small(self, n):
        return self.byte(2).byte(n)

    def count_raw(self, n):
        return self.byte(1).u32(n)


def write(harness, name, enc):
    d = os.path.join(HERE, "corpus", harness)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "seed-" + name), "wb") as f:
        f.write(bytes(enc.b))


# ---------------------------------------------------------------------------------------------------------
# fuzz_formulas: dbl, form, k, mu, alpha, max_slope, lo, hi, record a, record b, pair (s1, s2), sigma, d, omega.
# A record: n, then per sample weight, d1, length, kind (0 miss, 1 fraction of length, 2 two ends, 3 near light).

def formulas_header(e, authors=False):
    e.flag(authors)
    for _ in range(4):
        e.default()
    e.count_default().count_default()


def formulas():
    # A penumbra record: nine samples of which four hit halfway, defaults everywhere else.
    e = Enc()
    e.flag(False)
    formulas_header(e)
    e.byte(9)
    for i in range(9):
        e.default().default().default().byte(1 if i % 2 else 0)
        if i % 2:
            e.default()
    write("fuzz_formulas", "penumbra-float", e)

    # Contact (hits 2^-20 of the way) and an occluder near the light, merged; authors' form, double.
    e = Enc(dbl=True)
    e.flag(True)
    formulas_header(e, authors=True)
    e.byte(4)
    for _ in range(4):
        e.default().default().default().byte(1).scaled(-20)
    e.byte(2)
    for _ in range(2):
        e.default().default().default().byte(3).near(-1).near(-1)
    write("fuzz_formulas", "contact-and-light-double", e)

    # Bad samples: NaN weight, infinite d1, negative length, NaN and negative hit distances.
    e = Enc()
    e.flag(False)
    formulas_header(e)
    e.byte(5)
    e.special(NAN).default().default().byte(1).default()
    e.default().special(INF).default().byte(1).default()
    e.default().default().special(NEG_ONE).byte(1).default()
    e.default().default().default().byte(2).special(NAN).default()
    e.default().default().default().byte(2).special(NEG_ONE).special(NEG_BIG)
    e.byte(0)
    e.special(INF).special(ZERO)  # the arbitrary pair: no occluder
    e.special(ZERO).special(ZERO)  # σ = 0, d = 0
    write("fuzz_formulas", "bad-samples-float", e)

    # Point light and huge footprint, with extreme settings (μ = 2^40, max_slope tiny).
    e = Enc(dbl=True)
    e.flag(True)
    e.flag(False).default().scaled(40).default().special(TINY)
    e.count_small(1).count_raw(1 << 20)
    e.byte(1).default().default().default().byte(1).default()
    e.byte(0)
    e.default().default()
    e.special(ZERO).special(BIG)
    write("fuzz_formulas", "point-light-huge-pixel-double", e)


# ---------------------------------------------------------------------------------------------------------
# fuzz_filter: dbl, w-1, h-1, what (bit 7 spread, bit 3 light plane, bits 0-2 guides), truncation, max_radius,
# threshold, light normal (3), six strided layouts (vis, beta, d, normals, positions, ids), per-pixel values,
# then the output and scratch layouts.

def layout(e, pad=0, row_pad=0, offset=None):
    if pad == 0 and offset is None:
        e.byte(0).byte(row_pad)
    elif offset is None:
        e.byte((pad << 2) | 1).byte(row_pad)
    else:
        e.byte((pad << 2) | 3).byte(row_pad).byte(offset - 1)


def filter_image(dbl, w, h, what, rng, pads=(0, 0), specials=()):
    e = Enc(dbl)
    e.flag(dbl).byte(w - 1).byte(h - 1).byte(what)
    e.default().count_default().default().default().default().default()
    for _ in range(6):
        layout(e, *pads)
    for y in range(h):
        for x in range(w):
            if (x, y) in specials:
                e.special(specials[(x, y)])
            else:
                e.near(rng.randrange(-60, 60))  # visibility 0.5 · (1 ± ~0.9)
            e.default()  # pixel size
            e.near(rng.randrange(-64, 127))  # β: 0 to 3 px
            e.default().default().default()  # normal (0, 1, 0)
            e.default().default().default()  # position on the grid
            e.byte(rng.randrange(3))  # id
    layout(e, *pads)
    layout(e, *pads)
    return e


def filters():
    rng = random.Random(7)
    write("fuzz_filter", "all-guides-image-float", filter_image(False, 16, 12, 7, rng))
    write("fuzz_filter", "all-guides-light-plane-double", filter_image(True, 9, 14, 8 | 7, rng))
    write("fuzz_filter", "strided-normals-float", filter_image(False, 11, 7, 1, rng, pads=(4, 8)))
    write("fuzz_filter", "nonfinite-pixels-float",
          filter_image(False, 8, 8, 3, rng, specials={(1, 1): NAN, (4, 2): INF, (6, 6): NEG_INF, (3, 5): DENORM}))
    # spread_slopes with IDs: per pixel a flag, (s1, s2) when set, an id; then the radius.
    e = Enc()
    e.flag(False).byte(9).byte(6).byte(0x81)
    for _ in range(3):
        layout(e)
    for i in range(10 * 7):
        occluded = rng.random() < 0.2
        e.flag(occluded)
        if occluded:
            e.near(rng.randrange(-30, 60)).near(rng.randrange(-30, 30))
        e.byte(rng.randrange(3))
    e.count_small(2)
    write("fuzz_filter", "spread-with-ids-float", e)


# ---------------------------------------------------------------------------------------------------------
# fuzz_render: dbl, w-1, h-1, sampling, formulas, filter, radiance, light, G-buffer, oracle, shape, then
# frame_case: per-pixel counts flag, spp, outputs, unshadowed, cancel.

def render_header(e, w, h, initial=0, adaptive=True, pattern=0, weighting=0, authors=False, light_plane=False):
    e.flag(e.dbl).byte(w - 1).byte(h - 1)
    e.byte(initial).count_default().flag(not adaptive).byte(pattern).byte(weighting).u32(0).u32(0).flag(False)
    e.flag(authors).default().default().default().default()
    e.flag(light_plane).default().count_default().default().flag(False).count_default().default()
    for _ in range(9):
        e.default()
    e.flag(False)


def gbuffer(e, w, h, bad=None):
    for y in range(h):
        for x in range(w):
            if bad and (x, y) in bad:
                bad[(x, y)](e)
            else:
                for _ in range(7):
                    e.default()


def renders():
    # The default scene: 8x8 floor, square light, square occluder, span tracer.
    e = Enc()
    render_header(e, 8, 8)
    gbuffer(e, 8, 8)
    e.default().default().default().byte(0).byte(0).byte(0).byte(0)
    e.flag(False).count_default().byte(1)
    write("fuzz_render", "default-float", e)

    # Double, batch tracer, irradiance weighting, low-discrepancy samples, light-plane offsets; a table of bad
    # answers every third call: NaN, negative, at the light end, beyond it, huge.
    e = Enc(dbl=True)
    render_header(e, 6, 5, pattern=2, weighting=2, light_plane=True)
    gbuffer(e, 6, 5)
    e.default().default().default()
    e.byte(6).byte(2).byte(1)
    e.byte(3).default()  # NaN nearest
    e.byte(1).special(NEG_ONE).special(NEG_ONE)  # behind the origin
    e.byte(2).special(ONE).special(ONE)  # t = length (the light)
    e.byte(2).scaled(2).scaled(2)  # t = 2 length
    e.byte(1).special(BIG).special(BIG)  # huge
    e.byte(2).near(-32).near(16)  # a span inside
    e.byte(2)
    e.flag(False).count_default().byte(3)
    write("fuzz_render", "bad-answers-batch-double", e)

    # Float, nearest tracer, authors' form, Gaussian weighting; a NaN position, an infinite normal, a zero and a
    # denormal pixel size; cancelled at the second progress call.
    e = Enc()
    render_header(e, 5, 7, weighting=1, authors=True)

    def nan_position(e):
        e.special(NAN).default().default()
        for _ in range(4):
            e.default()

    def inf_normal(e):
        e.default().default().default().default().special(INF).default().default()

    def zero_size(e):
        for _ in range(6):
            e.default()
        e.special(ZERO)

    def denormal_size(e):
        for _ in range(6):
            e.default()
        e.special(DENORM)

    gbuffer(e, 5, 7, bad={(1, 1): nan_position, (2, 3): inf_normal, (3, 3): zero_size, (4, 5): denormal_size})
    e.default().default().default().byte(0).byte(0).byte(0)
    e.byte(1)
    e.flag(True)
    for _ in range(5 * 7):
        e.byte(rng_byte.randrange(80))
    e.count_default().byte(3)
    for _ in range(5 * 7):
        e.default()
    e.byte(2)
    write("fuzz_render", "bad-gbuffer-nearest-float", e)

    # A 1x8 strip, a grazing light almost in the receiver's plane, two-sided, contact occluder.
    e = Enc()
    e.flag(False).byte(0).byte(7)
    e.byte(3).count_small(32).flag(False).byte(0).byte(0).u32(5).u32(1).flag(False)
    e.flag(False).default().default().default().default()
    e.flag(False).default().count_default().default().flag(False).count_default().default()
    e.bits(10.0).special(EPS).default()  # corner (10, eps, -0.5)
    e.default().default().default()
    e.default().default().default()
    e.flag(True)
    gbuffer(e, 1, 8)
    e.default().default().scaled(-12)  # occluder 2^-12 above the floor
    e.byte(0).byte(0).byte(0)
    e.byte(0)
    e.flag(False).count_default().byte(3)
    write("fuzz_render", "strip-grazing-light-float", e)


rng_byte = random.Random(11)

if __name__ == "__main__":
    formulas()
    filters()
    renders()
