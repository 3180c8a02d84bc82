"""Real assets: load time of a textured glTF, and a textured scene beside Mitsuba 3.

`python -m bench assets [--peer mitsuba] [--quick] [--runs 3] [--out DIR]`

1. Load time (issue "Real assets": a textured glTF of 100k triangles with 2048^2 textures loads and starts
   rendering in <= 3 s).  The harness writes model.glb: a torus of 99,856 triangles with normals and UVs, a
   metallic-roughness material with three 2048^2 PNG textures inside the GLB (a wood-like base colour, metal
   stripes and roughness in B/G, a normal map of the wood's grooves), generated here from numpy.  Each of
   --runs fresh processes times its phases with the Python API: load (glTF parse, PNG decode, sRGB decode:
   `Scene.from_file`), BVH (`Tracer`), compile (the path kernels, once a process; reported apart: PoCL keeps
   its binaries in a disk cache, so only a first run pays the full compile: one more process with an empty
   cache measures that, compile_cold_s), first pass (one path a pixel at 640 x 480), then a pass at --spp
   for samples per second.  Medians are reported, with the bytes
   the textures take on the device (float4 texels).
2. The picture (--peer mitsuba): a torus of 8,192 triangles with a wood texture (Lambert, kd from an 8-bit
   sRGB PNG, bilinear, repeat) and a rough gold sphere (glTF metal, roughness 0.35) on a checker floor, under
   a generated HDR sky (a blue gradient, a bright sun disc) written as EXR: clrender's path tracer on the left,
   Mitsuba 3 (llvm_ad_rgb, the scene converted by tests/reference/mitsuba_scenes.py) on the right, at equal
   spp (--runs renders a side, at least 2), with the z-test's line (tests/reference/ztest.py over 16 x 16 blocks,
   the rows where the sky is seen directly left out: the two look the map up differently by design, piecewise
   constant against bilinear, mitsuba_scenes.mitsuba_envmap) under the table.  The torus reaches
   clrender as a glb node (its UVs from the file) and Mitsuba as the same arrays inline.
`--quick`: textures 256^2, 10k triangles, one timed process, a 96 x 64 picture at 16 spp.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .common import write_table

ROOT = Path(__file__).resolve().parents[1]
PICTURE_DEPTH = 6  # the picture's max depth, both renderers


# ---------------------------------------------------------------------- the asset
def torus(nu: int, nv: int, major: float = 1.0, minor: float = 0.4):
    """(positions, normals, uvs, faces) of a torus in the xz-plane: (nu + 1) (nv + 1) vertices (a seam copy for
    the UVs, u around the ring three times and v around the tube once), 2 nu nv triangles wound outwards."""
    u, v = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    a, b = 2 * np.pi * u, 2 * np.pi * v
    normal = np.stack([np.cos(a) * np.cos(b), np.sin(b), np.sin(a) * np.cos(b)], -1)
    centre = np.stack([major * np.cos(a), 0 * a, major * np.sin(a)], -1)
    positions = centre + minor * normal
    uvs = np.stack([3 * u, v], -1)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    k = (i * (nv + 1) + j).ravel()
    faces = np.concatenate([np.stack([k, k + 1, k + nv + 2], 1), np.stack([k, k + nv + 2, k + nv + 1], 1)])
    flat = lambda x: np.ascontiguousarray(x.reshape(-1, x.shape[-1]), np.float32)
    return flat(positions), flat(normal), flat(uvs), faces.astype(np.uint32)


def wood(n: int):
    """(base colour sRGB uint8, metallic-roughness uint8 (G roughness, B metallic), normal map uint8) of n x n
    texels: rings of a log seen along its grain, bent by low-frequency noise, dark grooves between rings, fibre
    noise of 6 codes."""
    rng = np.random.default_rng(7)
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n
    warp = sum(rng.uniform(0.02, 0.05) * np.sin(2 * np.pi * (f * x + rng.uniform()) + rng.uniform(0, 6) * y) for f in (1, 2, 3))
    phase = 14 * np.hypot(x - 0.3, 0.15 * (y - 0.5)) + 3 * warp
    ring = 0.5 + 0.5 * np.cos(2 * np.pi * phase)  # 1 in the pale wood, 0 in the grooves
    light, dark = np.array([205, 150, 95]), np.array([110, 60, 30])
    grain = rng.normal(0, 6, (n, n, 1))  # fibre noise: PNGs of real textures do not compress to nothing
    base = np.clip(dark + (light - dark) * ring[..., None] ** 0.6 + grain, 0, 255).astype(np.uint8)
    stripe = (np.sin(2 * np.pi * 6 * x) > 0.92).astype(np.float64)  # thin metal inlays
    rough = np.clip(0.35 + 0.5 * (1 - ring) * (1 - stripe) + grain[..., 0] / 255, 0, 1)
    mr = np.stack([0 * x, rough * 255, stripe * 255], -1).astype(np.uint8)
    gy, gx = np.gradient(0.004 * n * ring)
    nrm = np.stack([-gx, gy, np.ones_like(gx)], -1)  # glTF: +x right, +y up the image
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return base, mr, ((nrm * 0.5 + 0.5) * 255).astype(np.uint8)


def png_bytes(pixels: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def write_glb(path: Path, positions, normals, uvs, faces, images: list[bytes]) -> None:
    """A GLB of one mesh primitive with a metallic-roughness material whose base colour, metallic-roughness and
    normal textures are images[0:3], stored as PNG bufferViews (glTF 2.0 section 4.4)."""
    blobs, views, accessors = bytearray(), [], []

    def view(data: bytes, target=None) -> int:
        while len(blobs) % 4:
            blobs.append(0)
        views.append({"buffer": 0, "byteOffset": len(blobs), "byteLength": len(data), **({"target": target} if target else {})})
        blobs.extend(data)
        return len(views) - 1

    def accessor(array, kind, component=5126, target=34962, bounds=False) -> int:
        array = np.ascontiguousarray(array, np.float32 if component == 5126 else np.uint32)
        acc = {"bufferView": view(array.tobytes(), target), "componentType": component, "count": int(array.shape[0]), "type": kind}
        if bounds:
            acc["min"], acc["max"] = array.min(0).tolist(), array.max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    attributes = {
        "POSITION": accessor(positions, "VEC3", bounds=True),
        "NORMAL": accessor(normals, "VEC3"),
        "TEXCOORD_0": accessor(uvs, "VEC2"),
    }
    indices = accessor(faces.reshape(-1), "SCALAR", 5125, 34963)
    image_views = [view(data) for data in images]
    primitive = {"attributes": attributes, "indices": indices, **({"material": 0} if images else {})}
    doc = {
        "asset": {"version": "2.0", "generator": "clrender bench/assets.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [primitive]}],
        "materials": [
            {
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1}},
                "normalTexture": {"index": 2},
            }
        ],
        "textures": [{"source": i, "sampler": 0} for i in range(len(images))],
        "samplers": [{"magFilter": 9729, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"bufferView": v, "mimeType": "image/png"} for v in image_views],
        "buffers": [{"byteLength": len(blobs)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    if not images:  # geometry only (the picture's torus takes the scene's material)
        for key in ("materials", "textures", "samplers", "images"):
            del doc[key]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blobs.extend(b"\0" * (-len(blobs) % 4))
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blobs), 0x004E4942) + bytes(blobs)
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def grid(triangles: int) -> tuple[int, int]:
    """(nu, nv) of a torus of about `triangles` triangles, its cells about square (the ring 2.5 times the tube)."""
    nv = max(4, int(round(np.sqrt(triangles / 4))))
    return max(4, int(round(triangles / (2 * nv)))), nv


def make_model(path: Path, triangles: int, texture: int) -> dict:
    """Write the load-time asset; return what it holds."""
    positions, normals, uvs, faces = torus(*grid(triangles))
    start = time.perf_counter()
    images = [png_bytes(t) for t in wood(texture)]
    write_glb(path, positions, normals, uvs, faces, images)
    return dict(triangles=len(faces), texture=texture, png_mb=sum(map(len, images)) / 1e6, write_s=time.perf_counter() - start)


# ---------------------------------------------------------------------- load time, one fresh process per run
def child(model: str, width: int, height: int, spp: int) -> dict:
    """The phases of loading and starting to render `model`, in this (fresh) process."""
    t0 = time.perf_counter()
    from clrender import Renderer
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    t1 = time.perf_counter()
    scene = Scene.from_file(model)
    t2 = time.perf_counter()
    tracer = Tracer(scene)
    t3 = time.perf_counter()
    renderer = Renderer(scene, tracer=tracer, integrator="path", spp=1, width=width, height=height)
    t4 = time.perf_counter()
    first = renderer.run().timings["trace"]
    t5 = time.perf_counter()
    more = Renderer(scene, tracer=tracer, integrator="path", spp=spp, width=width, height=height).run().timings["trace"]
    return dict(
        import_s=t1 - t0,
        load_s=t2 - t1,
        bvh_s=t3 - t2,
        setup_s=t4 - t3,
        compile_s=renderer.compile_seconds,
        first_pass_s=first,
        to_first_image_s=t5 - t1,
        texture_bytes=int(sum(t.pixels.nbytes for t in scene.textures)),
        msamples_per_s=width * height * spp / more / 1e6,
    )


def time_loads(model: Path, runs: int, width: int, height: int, spp: int) -> dict:
    """Median of `runs` fresh processes' phases (each its own imports, device and kernels)."""
    import tempfile

    def one(env=None) -> dict:
        code = f"import json, bench.assets as a; print(json.dumps(a.child({str(model)!r}, {width}, {height}, {spp})))"
        proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=False, env=env)
        if proc.returncode:
            raise SystemExit(f"load-time child failed: {proc.stderr.strip().splitlines()[-1:]}")
        return json.loads(proc.stdout.strip().splitlines()[-1])

    with tempfile.TemporaryDirectory() as empty:  # one process with an empty PoCL kernel cache: the first-ever compile
        cold = one({**os.environ, "POCL_CACHE_DIR": empty})
    results = [one() for _ in range(runs)]
    row = {k: statistics.median(r[k] for r in results) for k in results[0]}
    row["without_compile_s"] = statistics.median(r["to_first_image_s"] - r["compile_s"] for r in results)
    row["compile_cold_s"] = cold["compile_s"]
    return row


# ---------------------------------------------------------------------- the picture
def sky(path: Path, width: int = 256) -> str:
    """An HDR sky as EXR: a gradient from a pale horizon to a deep zenith, dim ground, a sun disc 2 degrees
    across at 35 degrees elevation ~ 1e4 times the sky (rows run from the zenith, v = 0, down)."""
    import OpenImageIO as oiio

    h = width // 2
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(width) + 0.5) / width, indexing="ij")
    elevation = np.pi * (0.5 - v)
    t = np.clip(np.sin(elevation), 0, 1)[..., None]
    pixels = np.where(elevation[..., None] > 0, (1 - t) * [0.7, 0.75, 0.8] + t * [0.15, 0.3, 0.7], [0.2, 0.18, 0.16])
    phi = 2 * np.pi * u
    sun = np.array([np.cos(np.radians(35)) * np.cos(2.2), np.sin(np.radians(35)), np.cos(np.radians(35)) * np.sin(2.2)])
    d = np.stack([np.cos(elevation) * np.cos(phi), np.sin(elevation), np.cos(elevation) * np.sin(phi)], -1)
    pixels[d @ sun > np.cos(np.radians(2.0))] = [3000.0, 2700.0, 2200.0]
    pixels = np.ascontiguousarray(pixels, np.float32)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(width, h, 3, "float"))
    out.write_image(pixels)
    out.close()
    return str(path)


def picture_scenes(folder: Path, width: int, height: int, texture: int):
    """(clrender scene dict, the same for Mitsuba): the torus as a glb node for clrender, inline for Mitsuba."""
    from PIL import Image

    positions, normals, uvs, faces = torus(128, 32, 0.7, 0.28)
    positions = positions + [0.0, 0.28, 0.0]
    base, _, _ = wood(texture)
    Image.fromarray(base).save(folder / "wood.png")
    i, j = np.mgrid[0:1024, 0:1024]
    checker = np.where(((i // 16 + j // 16) % 2)[..., None] == 0, [200, 196, 186], [70, 74, 84]).astype(np.uint8)
    Image.fromarray(checker).save(folder / "checker.png")
    write_glb(folder / "torus.glb", positions, normals, uvs, faces, [])
    common = {
        "width": width,
        "height": height,
        "cameras": [{"position": [0.0, 1.3, 3.4], "look_at": [0.2, 0.4, 0.0], "up": [0, 1, 0], "fov": 38}],
        "environment": {"file": sky(folder / "sky.exr"), "intensity": 1.0, "rotation": 0.0},
        "textures": {"wood": {"file": str(folder / "wood.png")}, "checker": {"file": str(folder / "checker.png")}},
        "materials": {
            "wood": {"diffuse": [1, 1, 1], "diffuse_texture": "wood"},
            "floor": {"diffuse": [1, 1, 1], "diffuse_texture": "checker"},
            "gold": {"base_color": [1.0, 0.78, 0.34], "metallic": 1.0, "roughness": 0.35},
        },
        "objects": [
            {"type": "quad", "corner": [-20, 0, 20], "edge_a": [40, 0, 0], "edge_b": [0, 0, -40], "material": "floor"},
            {"type": "sphere", "center": [1.05, 0.45, -0.75], "radius": 0.45, "material": "gold"},
        ],
    }
    ours = json.loads(json.dumps(common))
    ours["objects"].append({"type": "mesh", "file": str(folder / "torus.glb"), "node": 0, "primitive": 0, "smooth": True, "material": "wood"})
    theirs = json.loads(json.dumps(common))
    mesh = {"type": "mesh", "vertices": positions, "faces": faces, "normals": normals, "uvs": uvs, "material": "wood"}
    theirs["objects"].append(mesh)
    return ours, theirs


def clrender_settings(spp: int) -> dict:
    """clrender's Renderer settings for the picture: the path tracer to PICTURE_DEPTH, as Mitsuba renders it."""
    return dict(integrator="path", spp=spp, max_depth=PICTURE_DEPTH)


def picture(out: Path, width: int, height: int, spp: int, texture: int, runs: int = 3) -> tuple[list, str]:
    """clrender | Mitsuba side by side (assets_pair.png), table rows and the z-test line."""
    from clrender import Renderer
    from clrender.image.files import write_display_image
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    from tests.reference import mitsuba_scenes
    from tests.reference.ztest import two_sample_z

    folder = out / "assets_scene"
    folder.mkdir(parents=True, exist_ok=True)
    ours_dict, theirs_dict = picture_scenes(folder, width, height, texture)
    scene = Scene.from_dict(ours_dict)
    tracer = Tracer(scene)
    ours, times = [], []
    for seed in range(runs):
        start = time.perf_counter()
        ours.append(Renderer(scene, tracer=tracer, seed=seed, **clrender_settings(spp)).run().image)
        times.append(time.perf_counter() - start)
    mi, loaded = mitsuba_scenes.load(theirs_dict, variant="llvm_ad_rgb", spp=spp, max_depth=PICTURE_DEPTH)
    theirs, their_times = [], []
    for seed in range(runs):
        start = time.perf_counter()
        theirs.append(mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=100 + seed))
        their_times.append(time.perf_counter() - start)
    write_display_image(out / "assets_pair.png", np.concatenate([ours[0], theirs[0]], axis=1))
    block = 16 if width % 16 == 0 and height % 16 == 0 else 8
    # The blocks where the sky is seen directly are left out: there the two renderers look the map up differently by
    # design (piecewise constant against bilinear: mitsuba_scenes.mitsuba_envmap), a 1e-4 difference the z-test finds.
    cam = ours_dict["cameras"][0]
    (ex, ey, ez), (tx, ty, tz) = cam["position"], cam["look_at"]
    pitch = np.arctan2(ey - ty, np.hypot(tx - ex, tz - ez))
    horizon = (1 - np.tan(pitch) / np.tan(np.radians(cam["fov"]) / 2)) / 2 * height  # the horizon's row
    top = int(np.ceil(horizon / block)) * block
    result = two_sample_z(np.stack(ours)[:, top:], np.stack(theirs)[:, top:], block=block)
    print(result.report())
    line = (
        f"picture {width}x{height} at {spp} spp: mean {np.mean(ours):.4f} (clrender) vs {np.mean(theirs):.4f} (Mitsuba); "
        f"z-test over {block}x{block} blocks below the horizon (rows {top}+), {runs} renders a side: worst p {result.worst_p:.3g} "
        f"(Šidák threshold {result.threshold:.3g}): {'pass' if result.passed else 'FAIL'}"
    )
    rows = [
        dict(renderer="clrender", seconds=statistics.median(times[1:] or times)),
        dict(renderer="mitsuba llvm_ad_rgb", seconds=statistics.median(their_times[1:] or their_times)),
    ]
    for r in rows:
        r["msamples_per_s"] = width * height * spp / r["seconds"] / 1e6
    return rows, line


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench assets", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--triangles", type=int, default=100_000, help="triangles of the load-time torus")
    ap.add_argument("--texture", type=int, default=2048, help="side of its three textures in texels")
    ap.add_argument("--runs", type=int, default=3, help="fresh processes timed; the median is reported")
    ap.add_argument("--spp", type=int, default=8, help="samples per pixel of the samples-per-second pass (640 x 480)")
    ap.add_argument("--peer", choices=("mitsuba",), help="also render the picture with Mitsuba 3 (llvm_ad_rgb) beside clrender")
    ap.add_argument("--picture", default="512x320", help="WIDTHxHEIGHT of the picture (--peer mitsuba)")
    ap.add_argument("--picture-spp", type=int, default=128, help="samples per pixel of each picture render")
    ap.add_argument("--quick", action="store_true", help="10k triangles, 256^2 textures, one run, a 96x64 picture at 16 spp")
    ap.add_argument("--out", default="bench/out", help="folder for assets.csv / assets.md, model.glb and assets_pair.png")
    args = ap.parse_args(argv)
    if args.quick:
        args.triangles, args.texture, args.runs, args.spp, args.picture, args.picture_spp = 10_000, 256, 1, 1, "96x64", 16
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    model = out / "model.glb"
    made = make_model(model, args.triangles, args.texture)
    print(f"{model}: {made['triangles']} triangles, 3 PNG textures {args.texture}^2 ({made['png_mb']:.1f} MB), written in {made['write_s']:.1f} s")
    row = time_loads(model, args.runs, 640, 480, args.spp)
    row = {"triangles": made["triangles"], "texture": args.texture, **row, "texture_mib": row["texture_bytes"] / 2**20}
    title = f"Loading a textured glTF ({made['triangles']} triangles, three {args.texture}^2 PNGs): median of {args.runs} processes"
    table = write_table(out, "assets", [row], title)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(table)
    if args.peer == "mitsuba":
        from tests.reference import mitsuba_scenes

        reason = mitsuba_scenes.unavailable("llvm_ad_rgb")
        if reason:
            print(f"mitsuba: not rendered: {reason}")
            return 0
        width, height = (int(x) for x in args.picture.split("x"))
        rows, line = picture(out, width, height, args.picture_spp, min(args.texture, 1024), runs=max(2, args.runs))
        print(write_table(out, "assets_picture", rows, f"The picture, {args.picture} at {args.picture_spp} spp"))
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
