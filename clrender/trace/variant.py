"""Kernel variants: one build of a kernel file, the switches that pick which of its code runs, the -D defines
derived from them, and the switches that turn others off, in words.

Every -D define a tracing or render kernel is built with comes from `Variant.defines()` (the kernels keep no
defaults of their own: common.h stops a build that lacks a knob).  A Tracer's variant is `Variant.of_tracer`;
a render's is that with `rendering(scene, write_aov)` and its integrator's kernel and film (integrators.py).
`clrender warmup` (clrender/warmup.py) lists every variant a render can reach, and
tests/kernels/test_variants.py compiles each.

Exclusions: the kernels switch some code off for other switches, silently.  The same conditions, stated here
(`shafts_on`, `query_packets`, `instance_packets`) and reported by `exclusions()`:
- shadow shafts (kernels/shaft.h, SHAFTS_ON) need a wide BVH (width 4 or 8), and alpha-tested and instanced
  scenes trace each shadow ray alone;
- query packets and paired walks (trace.cl, ITEM_PACKETS) need a wide BVH, 8 rays a work-item and no instances;
  instanced scenes walk eight rays as instance packets (INSTANCE_PACKETS) when ray packets are on;
- a wide top tree (TOP_WIDE) exists only over instances.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .knobs import DEFAULT_KNOBS, TraceKnobs

MAX_DEPTH_LIMIT = 16  # deepest mirror/refraction chain the kernels are built for
DEFAULT_BVH_WIDTH = 8  # 8-wide nodes (clrender/trace/bvh_wide.py), the fastest measured; 4; 2: the binary tree as built
# a Tracer's attributes that are a Variant's fields of the same names
TRACER_SWITCHES = ("use_bvh", "bvh_width", "count_prim_tests", "shadow_shafts", "ray_packets", "knobs", "top_wide")


@dataclass(frozen=True)
class Variant:
    filename: str = "trace.cl"  # kernels/<filename>
    use_bvh: bool = True  # False: every ray tests every primitive
    bvh_width: int = DEFAULT_BVH_WIDTH
    count_prim_tests: bool = False  # visits count primitive tests, not nodes
    shadow_shafts: bool = True  # area-light shadow rays through one shaft per shading point (where shafts_on)
    ray_packets: bool = True  # eight query rays that go the same way walk as one packet
    knobs: TraceKnobs = DEFAULT_KNOBS
    instanced: bool = False  # meshes placed by instances, each stored once (clrender/trace/instancing.py)
    top_wide: bool = False  # the instances' top tree in wide nodes (Tracer._top)
    rays_per_item: int = 8  # query rays per work-item: the device's WorkLayout
    render: bool = False  # a render kernel's build: WRITE_AOV, ALPHA_TEST and CULL_BACKFACES are its
    write_aov: bool = False  # the AOV writes compiled in
    alpha_test: bool = False  # alpha-tested materials (glTF MASK, BLEND): rays look past what they leave out (alpha.h)
    cull_backfaces: bool = False  # single-sided materials (glTF doubleSided false) hide back faces from camera rays
    extra: tuple = ()  # further sorted (name, value) defines: the path tracer's film (film.defines), the BVH builder's
    tracing: bool = True  # False: a kernel file without the traversal (bvh_build.cl): `extra` alone
    label: str = ""  # what it is for, in words (`clrender warmup --list` prints these)

    @classmethod
    def of_tracer(cls, tracer) -> Variant:
        """The variant of a Tracer's ray queries (trace.cl): its switches of the same names, its instances, its layout."""
        same = {name: getattr(tracer, name) for name in TRACER_SWITCHES}
        return cls(**same, instanced=tracer.instances is not None, rays_per_item=tracer.layout.rays_per_item)

    def rendering(self, scene, write_aov: bool) -> Variant:
        """This Tracer variant as a render kernel's for `scene` (its materials' alpha and sidedness)."""
        materials = scene.materials.values()
        alpha_test = any(m.alpha_mode != "opaque" for m in materials)
        return replace(self, render=True, write_aov=write_aov, alpha_test=alpha_test, cull_backfaces=not all(m.double_sided for m in materials))

    @property
    def shafts_on(self) -> bool:
        """kernels/shaft.h's SHAFTS_ON."""
        return self.shadow_shafts and self.use_bvh and self.bvh_width >= 4 and not self.alpha_test and not self.instanced

    @property
    def query_packets(self) -> bool:
        """trace.cl's ITEM_PACKETS (packets when ray_packets, else pairs of walks)."""
        return self.use_bvh and self.bvh_width >= 4 and self.rays_per_item == 8 and not self.instanced

    @property
    def instance_packets(self) -> bool:
        """trace.cl's INSTANCE_PACKETS."""
        return self.use_bvh and self.bvh_width >= 4 and self.rays_per_item == 8 and self.instanced and self.ray_packets

    def exclusions(self) -> list[str]:
        """Each switch asked for that another turns off, and why, in words (empty: every switch is on as asked)."""
        if not self.tracing:
            return []
        said = []
        narrow = "no BVH" if not self.use_bvh else f"a {self.bvh_width}-wide BVH" if self.bvh_width < 4 else ""
        if self.shadow_shafts and not self.shafts_on:
            why = [narrow, "alpha-tested materials" if self.alpha_test else "", "instances" if self.instanced else ""]
            said.append(f"shadow shafts off: {', '.join(w for w in why if w)} (each shadow ray is traced alone)")
        if self.ray_packets and not (self.query_packets or self.instance_packets):
            why = [narrow, f"{self.rays_per_item} ray a work-item" if self.rays_per_item != 8 else ""]
            said.append(f"ray packets off: {', '.join(w for w in why if w)} (each query ray walks alone)")
        if self.top_wide and not (self.instanced and self.use_bvh):
            said.append("wide top tree off: " + ("no instances" if not self.instanced else "no BVH"))
        return said

    def defines(self) -> dict:
        """The -D defines of this build."""
        if not self.tracing:
            return dict(self.extra)
        defines = {
            "USE_BVH": int(self.use_bvh),
            "MAX_DEPTH": MAX_DEPTH_LIMIT,
            "STACK_SIZE": self.knobs.stack_size,
            "BVH_WIDTH": self.bvh_width,
            "WIDE_STACK_SIZE": self.knobs.wide_stack_size(max(self.bvh_width, 4)),
            "COUNT_PRIM_TESTS": int(self.count_prim_tests),
            "RAYS_PER_ITEM": self.rays_per_item,
            "SHADOW_SHAFTS": int(self.shadow_shafts),
            "SHAFT_CANDIDATES": self.knobs.shaft_candidates,
            "RAY_PACKETS": int(self.ray_packets),
            "RENDER_BUILD": int(self.render),  # trace.cl: the render kernel alone (1) or the ray queries (0)
            **({"INSTANCED": 1} if self.instanced else {}),  # only when there are: the flat scene's kernels are the ones before
            **({"TOP_WIDE": 1} if self.instanced and self.top_wide else {}),
        }
        if self.render:  # scenes without alpha-tested or single-sided materials keep the kernels they had
            defines["WRITE_AOV"] = int(self.write_aov)
            defines.update({name: 1 for name, on in (("ALPHA_TEST", self.alpha_test), ("CULL_BACKFACES", self.cull_backfaces)) if on})
        return {**defines, **dict(self.extra)}

    def key(self) -> tuple:
        """The defines as sorted (name, value) pairs: Device.program's cache key."""
        return tuple(sorted(self.defines().items()))

    def build(self, device):
        """The program of this variant on `device` (built once a process; pyopencl caches the binary on disk)."""
        return device.program(self.filename, self.defines())
