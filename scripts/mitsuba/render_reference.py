#!/usr/bin/env python3
"""Independent reference images from Mitsuba 3 for a scene dumped by `dump_scene`.

Reads the scene JSON written by `cargo run -p tests --example dump_scene` (triangles, a material
index per triangle, albedo (base colour) + emitted radiance per material and, for glTF
metal-roughness materials, `"model": "metal-roughness"` with `metallic` and `roughness`; a
pinhole camera) and renders it with Mitsuba 3's `path` integrator under this workspace's
conventions:

- a material without `model` (or `"model": "diffuse"`) is Lambertian and two-sided (`twosided`
  around `diffuse`); a metal-roughness one is the plugin `gltf_bsdf.py`
  (`gltf_metal_roughness`: glTF 2.0's BRDF with Kulla-Conty energy compensation, as the
  renderer's `restir_world::brdf`, two-sided; `--bsdf-variant` picks one of its controls);
- every emitter emits its radiance from both faces. Mitsuba's `area` emitter is one-sided, so
  each emissive triangle is rendered twice: as given, and as a copy with the opposite winding
  moved a hair (1e-6 of the scene's size) behind it. A ray reaching the light from either side
  hits the copy whose front faces it first; both copies reflect (same two-sided BSDF);
- the camera is a pinhole (`perspective`, vertical field of view, `fov_axis = y`) with a box
  filter of one pixel (each pixel is the plain average over its area) and the `independent`
  sampler, as in the renderer's `render_primary`;
- `max_depth = bounces + 2`: emission seen + direct light + `bounces` bounces of indirect
  light, i.e. the renderer's combined image at `bounces` bounces. Russian roulette is off
  (`rr_depth` above `max_depth`), so every depth is computed exactly.

Writes one float32 RGB OpenEXR per bounce count (`<out-dir>/<prefix>-bounces-<N>.exr`) and
prints the per-channel image means and the render time of each.

    python3 scripts/mitsuba/render_reference.py tests/data/mitsuba/cornell-64x64.json \
        --bounces 1-8 --spp 4096 --seed 1 --out-dir tests/data/mitsuba

Variants: `scalar_rgb` (the default; what made the diffuse images) or a JIT one
(`--variant llvm_ad_rgb`: needs LLVM >= 16, e.g. Debian's `libllvm19`; the Python BSDF runs
vectorised there, where `scalar_rgb` would call it once per ray). `--threads` sets Dr.Jit's
thread count (JIT variants). `--passes K` renders the samples as K renders of spp / K at
seeds `seed * 65536 + i` (memory stays small in the JIT variants) and prints each image
mean's standard error from the passes' scatter, and that of each indirect image (the image at
N bounces minus the direct one, pass by pass: the same seed draws the same first segments at
every depth, so their difference keeps only the deeper bounces' noise).
"""

import argparse
import json
import os
import sys
import time

import drjit as dr
import numpy as np
import mitsuba as mi

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_bsdf  # noqa: E402


def parse_bounces(text):
    """'3' -> [3]; '1-8' -> [1, ..., 8]; '1,3,5' -> [1, 3, 5]."""
    out = []
    for part in text.split(","):
        if "-" in part:
            lo, hi = (int(x) for x in part.split("-"))
            out.extend(range(lo, hi + 1))
        else:
            out.append(int(part))
    if not out or min(out) < 0:
        raise argparse.ArgumentTypeError(f"bad bounce list {text!r}")
    return out


def make_mesh(name, tris, bsdf, radiance=None):
    """A Mitsuba mesh of independent triangles (no shared vertices, no normals: flat shading)."""
    tris = np.asarray(tris, dtype=np.float32).reshape(-1, 3, 3)
    props = mi.Properties()
    props["bsdf"] = bsdf
    if radiance is not None:
        props["emitter"] = mi.load_dict(
            {"type": "area", "radiance": {"type": "rgb", "value": radiance}}
        )
    mesh = mi.Mesh(
        name,
        vertex_count=3 * len(tris),
        face_count=len(tris),
        has_vertex_normals=False,
        has_vertex_texcoords=False,
        props=props,
    )
    params = mi.traverse(mesh)
    scalar = mi.variant().startswith("scalar")
    floats, uints = (dr.scalar.ArrayXf, dr.scalar.ArrayXu) if scalar else (mi.Float, mi.UInt32)
    params["vertex_positions"] = floats(tris.reshape(-1))
    params["faces"] = uints(np.arange(3 * len(tris), dtype=np.uint32))
    params.update()
    return mesh


def material_bsdf(mat, bsdf_variant):
    """The two-sided BSDF of one JSON material."""
    model = mat.get("model", "diffuse")
    if model == "diffuse":
        return mi.load_dict(
            {
                "type": "twosided",
                "material": {
                    "type": "diffuse",
                    "reflectance": {"type": "rgb", "value": mat["albedo"]},
                },
            }
        )
    if model == "metal-roughness":
        base = mat["albedo"]
        return mi.load_dict(
            {
                "type": "gltf_metal_roughness",
                "base_r": float(base[0]),
                "base_g": float(base[1]),
                "base_b": float(base[2]),
                "metallic": float(mat["metallic"]),
                "roughness": float(mat["roughness"]),
                "variant": bsdf_variant,
            }
        )
    raise SystemExit(f"unknown material model {model!r}")


def build_scene(doc, bounces, spp, bsdf_variant="full"):
    tris = np.asarray(doc["triangles"], dtype=np.float64)  # (T, 3, 3)
    mat_of = np.asarray(doc["material"], dtype=np.int64)
    mats = doc["materials"]
    cam = doc["camera"]
    lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    extent = float(np.max(hi - lo))

    d = {
        "type": "scene",
        "integrator": {
            "type": "path",
            "max_depth": bounces + 2,
            "rr_depth": bounces + 1000,
            "hide_emitters": False,
        },
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": float(cam["vfov_deg"]),
            "near_clip": 1e-5 * extent,
            "far_clip": 1e3 * extent,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["eye"], target=cam["target"], up=cam["up"]
            ),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {
                "type": "hdrfilm",
                "width": int(cam["width"]),
                "height": int(cam["height"]),
                "pixel_format": "rgb",
                "component_format": "float32",
                "sample_border": False,
                "rfilter": {"type": "box"},
            },
        },
    }
    for m, mat in enumerate(mats):
        sel = tris[mat_of == m]
        if len(sel) == 0:
            continue
        bsdf = material_bsdf(mat, bsdf_variant)
        emission = mat["emission"]
        if any(e > 0 for e in emission):
            d[f"mat{m}-front"] = make_mesh(f"mat{m}-front", sel, bsdf, emission)
            # The back face: reversed winding (v0, v2, v1), moved behind the front one along
            # the front's normal, so it is hit first from behind and second (never) from front.
            n = np.cross(sel[:, 1] - sel[:, 0], sel[:, 2] - sel[:, 0])
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            back = sel[:, [0, 2, 1]] - (1e-6 * extent) * n[:, None, :]
            d[f"mat{m}-back"] = make_mesh(f"mat{m}-back", back, bsdf, emission)
        else:
            d[f"mat{m}"] = make_mesh(f"mat{m}", sel, bsdf)
    return mi.load_dict(d)


def write_exr(path, img):
    """float32 RGB OpenEXR (Mitsuba's writer; its default compression). The writer waits on a
    worker of Dr.Jit's thread pool, and with one thread (`--threads 1`) never returns
    (Mitsuba 3.9.1): the pool gets two for the write."""
    threads = dr.thread_count()
    dr.set_thread_count(max(threads, 2))
    try:
        bmp = mi.Bitmap(
            np.ascontiguousarray(img, dtype=np.float32),
            pixel_format=mi.Bitmap.PixelFormat.RGB,
        )
        bmp.write(path)
    finally:
        dr.set_thread_count(threads)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="scene JSON from `dump_scene`")
    ap.add_argument("--bounces", type=parse_bounces, default=[1], help="e.g. 1-8, or 1,3")
    ap.add_argument("--spp", type=int, default=4096, help="samples per pixel")
    ap.add_argument("--seed", type=int, default=1, help="seed passed to mi.render")
    ap.add_argument("--out-dir", default=".", help="where the EXRs go")
    ap.add_argument(
        "--variant",
        default="scalar_rgb",
        help="Mitsuba variant: scalar_rgb (default) or llvm_ad_rgb (fast with the glTF plugin)",
    )
    ap.add_argument("--threads", type=int, default=1, help="Dr.Jit threads (JIT variants)")
    ap.add_argument(
        "--passes", type=int, default=1, help="render spp as this many passes (seeds differ)"
    )
    ap.add_argument(
        "--bsdf-variant",
        default="full",
        choices=gltf_bsdf.VARIANTS,
        help="the glTF plugin's model: full, or a control (see gltf_bsdf.py)",
    )
    ap.add_argument(
        "--prefix",
        default=None,
        help="file name prefix (default: the JSON's name without .json)",
    )
    args = ap.parse_args()

    mi.set_variant(args.variant)
    if args.variant.startswith(("llvm", "cuda")):
        dr.set_thread_count(args.threads)
    gltf_bsdf.register(mi, dr)
    if args.passes < 1 or args.spp % args.passes:
        sys.exit(f"--passes {args.passes} must divide --spp {args.spp}")
    per_pass = args.spp // args.passes

    with open(args.scene) as f:
        doc = json.load(f)
    prefix = args.prefix or os.path.splitext(os.path.basename(args.scene))[0]
    os.makedirs(args.out_dir, exist_ok=True)
    print(
        f"mitsuba {mi.__version__} ({mi.variant()}), {len(doc['triangles'])} triangles, "
        f"{doc['camera']['width']}x{doc['camera']['height']}, {args.spp} spp "
        f"({args.passes} passes), seed {args.seed}, glTF BSDF {args.bsdf_variant}",
        flush=True,
    )
    pass_means = {}
    for n in args.bounces:
        scene = build_scene(doc, n, per_pass, args.bsdf_variant)
        t0 = time.perf_counter()
        img = None
        means = []
        for i in range(args.passes):
            seed = args.seed if args.passes == 1 else args.seed * 65536 + i
            one = np.array(mi.render(scene, spp=per_pass, seed=seed), dtype=np.float64)
            means.append(one.reshape(-1, 3).mean(0))
            img = one if img is None else img + one
        img /= args.passes
        dt = time.perf_counter() - t0
        pass_means[n] = np.array(means)
        if not np.all(np.isfinite(img)):
            sys.exit(f"bounces {n}: non-finite pixels")
        path = os.path.join(args.out_dir, f"{prefix}-bounces-{n}.exr")
        write_exr(path, img)
        mean = img.reshape(-1, 3).mean(0)
        se = ""
        if args.passes > 1:
            rel = pass_means[n].std(0, ddof=1) / np.sqrt(args.passes) / mean
            se = f"  (standard error {rel[0]:.3%} {rel[1]:.3%} {rel[2]:.3%})"
        print(
            f"bounces {n} (max_depth {n + 2}): mean rgb {mean[0]:.6f} {mean[1]:.6f} "
            f"{mean[2]:.6f}{se}  {dt:.1f} s  -> {path}",
            flush=True,
        )
    if args.passes > 1 and 0 in pass_means:
        for n in args.bounces:
            if n == 0:
                continue
            d = pass_means[n] - pass_means[0]
            mean = d.mean(0)
            rel = d.std(0, ddof=1) / np.sqrt(args.passes) / mean
            print(
                f"indirect at {n} bounces: mean rgb {mean[0]:.6f} {mean[1]:.6f} {mean[2]:.6f} "
                f"(standard error {rel[0]:.3%} {rel[1]:.3%} {rel[2]:.3%})",
                flush=True,
            )


if __name__ == "__main__":
    main()
