#!/usr/bin/env python3
"""Compares two renders of the same scene (linear RGB EXRs, same size): per-channel image means
and their relative difference, and whether the per-pixel differences look like noise.

    python3 scripts/mitsuba/compare.py A.exr B.exr [--a2 A_other_seed.exr --b2 B_other_seed.exr]

With a second render of each at another seed (--a2, --b2), the noise of each is measured
(var(A - A2) / 2) and the difference A - B is compared with it: for unbiased renders of the same
image, var(A - B) ~ var_noise(A) + var_noise(B), and the mean differences over 8x8 blocks stay
within a few standard errors. Also prints the same statistic for B mirrored left-right,
upside down and shifted by one pixel, which a convention mismatch would match better.
"""

import argparse

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def load(path):
    img = np.array(mi.Bitmap(path), dtype=np.float64)
    if img.ndim != 3 or img.shape[2] < 3:
        raise SystemExit(f"{path}: expected an RGB image, got shape {img.shape}")
    return img[:, :, :3]


def block_means(img, b=8):
    h, w, c = img.shape
    return img[: h - h % b, : w - w % b].reshape(h // b, b, w // b, b, c).mean((1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--a2", help="A rendered at another seed (noise of A)")
    ap.add_argument("--b2", help="B rendered at another seed (noise of B)")
    args = ap.parse_args()
    a, b = load(args.a), load(args.b)
    if a.shape != b.shape:
        raise SystemExit(f"sizes differ: {a.shape} vs {b.shape}")
    ma, mb = a.reshape(-1, 3).mean(0), b.reshape(-1, 3).mean(0)
    print(f"mean A  {ma[0]:.6f} {ma[1]:.6f} {ma[2]:.6f}   ({args.a})")
    print(f"mean B  {mb[0]:.6f} {mb[1]:.6f} {mb[2]:.6f}   ({args.b})")
    rel = (ma - mb) / mb
    print(f"(A-B)/B {rel[0]:+.4%} {rel[1]:+.4%} {rel[2]:+.4%}")
    if not (args.a2 and args.b2):
        return
    da, db = a - load(args.a2), b - load(args.b2)
    na = np.var(da, axis=(0, 1)) / 2
    nb = np.var(db, axis=(0, 1)) / 2
    expected = na + nb
    # Noise variance of each 8x8 block mean, from that block's own pixels (the noise is far
    # from uniform: pixels on the light's edge are orders of magnitude noisier than the rest).
    bexp = block_means((da**2 + db**2) / 2) / 64

    def stats(bb):
        d = a - bb
        ratio = np.var(d, axis=(0, 1)) / expected
        z = block_means(d) / np.sqrt(bexp)
        return ratio, np.abs(z).max(axis=(0, 1)), np.sqrt((z**2).mean(axis=(0, 1)))

    print("per-pixel noise sd: A", np.sqrt(na).round(5), " B", np.sqrt(nb).round(5))
    print("var(A-B) / (noise A + noise B) per channel; 8x8 block mean z: max |z|, rms z")
    for name, bb in [
        ("as is", b),
        ("B mirrored left-right", b[:, ::-1]),
        ("B upside down", b[::-1]),
        ("B shifted 1 px right", np.roll(b, 1, axis=1)),
        ("B shifted 1 px down", np.roll(b, 1, axis=0)),
    ]:
        r, zmax, zrms = stats(bb)
        print(f"  {name:24s} ratio {r.round(3)}  max|z| {zmax.round(2)}  rms z {zrms.round(2)}")


if __name__ == "__main__":
    main()
