"""Mutation testing: put one small deliberate bug into the code, run the tests that should notice it.

    python -m bench mutants                  # every mutant, one at a time
    python -m bench mutants --list           # the list, and whether each snippet still applies
    python -m bench mutants --only ID [ID …] # just these (ids or fnmatch patterns, e.g. 'shade-*')
    python -m bench mutants --jobs 2         # two mutants at a time (the default is 1)
    python -m bench mutants --only mirror-off --tests tests/test_render.py   # does this file alone catch it?

Each mutant is (id, file, old snippet, new snippet, what it breaks, test files).  The
harness snapshots the working tree once (git's tracked files plus untracked ones git does
not ignore, as they are on disk now, uncommitted edits included) into a temporary folder,
and for every mutant copies that snapshot, replaces the old snippet, which must occur
exactly once, by the new one, and runs its test files there with
`python -m pytest -x -q -m "not slow"`, the copy as the working directory and on PYTHONPATH
(for tests that start `python -m clrender` elsewhere), so the copy's clrender/ is imported
before the editable install's, and its kernels/ are built (clrender/package_data.py finds them
beside the package); the harness checks this before it starts, and the `sanity-*` mutants must
be killed too.  The repository itself is never modified.

A mutant is *killed* when the tests fail (or time out), *survived* when they pass,
*stale* when its old snippet no longer occurs exactly once (the code moved on: update the
snippet), and is never run then.  Results go to bench/out/mutants.{md,csv}.
Documented in docs/testing.md, with every survivor explained.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_PYTHON = ROOT / ".venv" / "bin" / "python"


@dataclass(frozen=True)
class Mutant:
    id: str
    file: str  # path relative to the repository root
    old: str  # exact snippet, must occur once
    new: str
    what: str  # the bug, in words
    tests: tuple  # test files (relative paths); missing ones are skipped


# Test files per area, the quickest and most telling first (pytest -x stops at the first failure).
TRACE = (
    "tests/test_optics.py",
    "tests/test_reference_renderer.py",
    "tests/test_fresnel_tir.py",
    "tests/test_shading_rules.py",
    "tests/test_ties.py",
    "tests/test_render.py",
    "tests/test_outputs.py",
    "tests/test_sampling.py",
    "tests/test_refraction.py",
    "tests/test_area_light.py",
    "tests/test_intersect.py",
    "tests/test_exact_rays.py",
    "tests/test_bvh.py",
    "tests/test_bvh_wide.py",
    "tests/test_mesh_normals.py",
    "tests/test_aov.py",
    "tests/test_edges.py",
)
PACKET = ("tests/test_ray_packets.py",) + TRACE
SAMPLING = ("tests/test_sampling.py", "tests/test_outputs.py") + TRACE
OUTPUT = (
    "tests/test_outputs.py",
    "tests/test_cli.py",
    "tests/test_cli_args.py",
    "tests/test_convolve_cli.py",
    "tests/test_filters.py",
    "tests/test_display.py",
    "tests/test_faults.py",
)
SPLAT = ("tests/test_splat_gauss.py", "tests/test_splat_gauss_fit.py", "tests/test_splat_gauss_cli.py")
VORONOI = ("tests/test_voronoi.py",)


def M(id, file, old, new, what, tests=TRACE):  # noqa: N802 - a table row
    return Mutant(id, file, old, new, what, tuple(dict.fromkeys(tests)))


MUTANTS = [
    # ---- sanity: the copy's code is what runs (both must be killed, or the harness tests nothing)
    M(
        "sanity-kernel",
        "kernels/trace.cl",
        "colour_out[gid] = (float4)(sum / weight_sum, 1.0f);",
        "colour_out[gid] = (float4)(0.0f);",
        "every pixel black (the copy's kernels are the ones built)",
    ),
    M(
        "sanity-host",
        "clrender/image/files.py",
        '"""The sRGB transfer function (IEC 61966-2-1), for linear values in [0, 1]."""',
        '"""The sRGB transfer function (IEC 61966-2-1), for linear values in [0, 1]."""\n    x = x * 0.5',
        "sRGB encoding of half the value (the copy's Python is the one imported)",
        OUTPUT,
    ),
    # ---- kernels/shade.h: the Whitted rules (the list first)
    M(
        "mirror-off",
        "kernels/shade.h",
        "float3 w_reflect = w * (1.0f - transparency) * mirror;",
        "float3 w_reflect = w * (1.0f - transparency) * 0.0f;",
        "mirror reflection switched off",
    ),
    M(
        "reflect-factor-1",
        "kernels/shade.h",
        "return d - 2.0f * dot3(d, n) * n;",
        "return d - 1.0f * dot3(d, n) * n;",
        "reflection r = d - (d.n) n instead of d - 2 (d.n) n",
    ),
    M(
        "refract-eta-1",
        "kernels/shade.h",
        "refract_dir(d, n_shade, n1 / n2, &refracted)",
        "refract_dir(d, n_shade, 1.0f, &refracted)",
        "refraction without bending (eta = 1)",
    ),
    M(
        "leaving-glass-keeps-ior",
        "kernels/shade.h",
        "float n2 = front_face ? ior : 1.0f;",
        "float n2 = front_face ? ior : ior;",
        "a ray leaving glass keeps the glass's IOR instead of air's",
    ),
    M(
        "max-depth-1",
        "kernels/shade.h",
        "if (depth >= sc->max_depth) continue;",
        "if (depth >= 1) continue;",
        "max depth cut to 1 whatever --max-depth says",
    ),
    M("smooth-normals-ignored", "kernels/shade.h", "if (obj.y) {", "if (0) {", "smooth meshes shaded flat (vertex normals ignored)"),
    M(
        "smooth-barycentrics-swapped",
        "kernels/shade.h",
        "h.u * vn[1].xyz + h.v * vn[2].xyz",
        "h.v * vn[1].xyz + h.u * vn[2].xyz",
        "barycentric weights of the vertex normals swapped",
    ),
    M("blinn-half-l-minus-v", "kernels/shade.h", "float3 h = unit(l + v);", "float3 h = unit(l - v);", "Blinn-Phong half vector built as l - v"),
    M(
        "schlick-one",
        "kernels/shade.h",
        "return r0 + (1.0f - r0) * m * m * m * m * m;",
        "return 1.0f;",
        "Schlick's Fresnel term always 1 (--fresnel reflects everything)",
    ),
    M(
        "shininess-ignored",
        "kernels/shade.h",
        "pow_unit(max_f(dot3(n, h), 1e-30f), shininess)",
        "pow_unit(max_f(dot3(n, h), 1e-30f), 1.0f)",
        "Blinn-Phong exponent fixed at 1",
    ),
    M(
        "ambient-dropped",
        "kernels/shade.h",
        "float3 surface = sc->ambient * kd.xyz +",
        "float3 surface = 0.0f * sc->ambient * kd.xyz +",
        "ambient term dropped",
    ),
    M(
        "shadows-ignored",
        "kernels/shade.h",
        "total += (T * weight * falloff) * colour",
        "total += (weight * falloff) * colour",
        "shadow rays' transmittance ignored (no shadows)",
    ),
    M(
        "area-weight-n",
        "kernels/shade.h",
        "float weight = intensity / (float)(n_side * n_side);",
        "float weight = intensity / (float)(n_side);",
        "area light divided by n instead of n^2",
    ),
    M(
        "inverse-square-is-inverse",
        "kernels/shade.h",
        "falloff = 1.0f / (dist * dist);\n                        /*",
        "falloff = 1.0f / dist;\n                        /*",
        "inverse-square falloff as 1/r (point lights)",
    ),
    M(
        "area-inverse-square-is-inverse",
        "kernels/shade.h",
        "falloff = 1.0f / (dist * dist);\n                    /*",
        "falloff = 1.0f / dist;\n                    /*",
        "inverse-square falloff as 1/r (area lights)",
    ),
    M("directional-sign", "kernels/shade.h", "l = -unit(pos);", "l = unit(pos);", "directional light taken from the direction it travels to"),
    M(
        "area-cos-dropped",
        "kernels/shade.h",
        "falloff *= area * as_float8(as_uint8(cos_light) & 0x7fffffffu);",
        "falloff *= area;",
        "area light's cos(theta') dropped (inverse-square units)",
    ),
    M(
        "tir-loses-light",
        "kernels/shade.h",
        "w_reflect += w * transparency;",
        "w_reflect += 0.0f * w * transparency;",
        "total internal reflection reflects nothing",
    ),
    M(
        "fresnel-no-1-minus-F",
        "kernels/shade.h",
        "w_refract = w * transparency * (1.0f - F);",
        "w_refract = w * transparency;",
        "with --fresnel the refracted share is not reduced by F",
    ),
    M(
        "schlick-wrong-side",
        "kernels/shade.h",
        "float c = (n1 <= n2) ? cos_i : cos_t;",
        "float c = cos_i;",
        "Schlick uses the incident angle also when leaving the denser medium",
    ),
    M(
        "refract-sign",
        "kernels/shade.h",
        "*out = unit(eta * d + (eta * cos_i - cos_t) * n);",
        "*out = unit(eta * d + (eta * cos_i + cos_t) * n);",
        "Snell's vector formula with + cos_t",
    ),
    M("refracted-origin-outside", "kernels/shade.h", "-n_geo), n2);", "n_geo), n2);", "refracted ray starts on the near side of the surface"),
    M(
        "front-face-flipped",
        "kernels/shade.h",
        "bool front_face = dot3(d, n_geo) < 0.0f;",
        "bool front_face = dot3(d, n_geo) > 0.0f;",
        "entering and leaving swapped",
    ),
    M(
        "mirror-keeps-surface",
        "kernels/shade.h",
        "float3 surface_weight = w * (1.0f - transparency) * (1.0f - mirror);",
        "float3 surface_weight = w * (1.0f - transparency);",
        "a mirror keeps all of its own shading",
    ),
    M(
        "shadow-fraction-n",
        "kernels/shade.h",
        "shadow[li] = visible / (float)(n_side * n_side);",
        "shadow[li] = visible / (float)(n_side);",
        "recorded light visibility divided by n, not n^2",
    ),
    M(
        "shading-normal-no-fallback",
        "kernels/shade.h",
        "if (dot3(n_shade, d) >= 0.0f) n_shade = n_geo;",
        "if (dot3(n_shade, d) >= 2.0f) n_shade = n_geo;",
        "an interpolated normal facing away is kept",
    ),
    # ---- kernels/intersect.h: hits and shadow transmittance
    M(
        "glass-shadow-T",
        "kernels/intersect.h",
        "return crossings == 2 ? transparency * transparency : transparency;",
        "return transparency;",
        "shadow through a glass sphere attenuated once (T) instead of twice (T^2)",
    ),
    M(
        "triangles-never-shadow",
        "kernels/intersect.h",
        "crossings = hit_triangle(",
        "crossings = 0 && hit_triangle(",
        "triangles never block shadow rays",
    ),
    M("sphere-far-root", "kernels/intersect.h", "if (t0 > t_min && t0 < t_max) return t0;", "if (0) return t0;", "sphere hit at the far root"),
    M(
        "tie-to-higher-id",
        "kernels/intersect.h",
        "t != INF_T && id < best->id",
        "t != INF_T && id > best->id",
        "equal-distance ties go to the higher primitive id",
    ),
    M(
        "bvh-far-child-dropped",
        "kernels/intersect.h",
        "if (stack_t[sp] <= best.t * 1.0000004f) next = stack[sp];",
        "if (stack_t[sp] < 0.0f) next = stack[sp];",
        "BVH never visits a far child",
    ),
    M(
        "occluded-opaque-passes",
        "kernels/intersect.h",
        "            if (opaque_only) return 0.0f;\n            for (int k = 0; k < BLOCK_LANES; ++k)",
        "            if (opaque_only) return 1.0f;\n            for (int k = 0; k < BLOCK_LANES; ++k)",
        "any-hit query ignores blockers",
    ),
    M("sphere-one-crossing", "kernels/intersect.h", "+ (t1 > ", "+ 0 * (t1 > ", "a shadow ray counts only one crossing of a sphere"),
    M(
        "wide-prunes-too-much",
        "kernels/intersect.h",
        "key_t(key) > t_max * 1.0000004f) return;",
        "key_t(key) > t_max * 0.5f) return;",
        "wide BVH skips boxes that can still hold a nearer hit",
    ),
    M(
        "wide-slab-exit-at-near",
        "kernels/intersect.h",
        "*t_exit = far < *t_exit ? far : *t_exit;",
        "*t_exit = near < *t_exit ? near : *t_exit;",
        "wide-node slab test takes the near plane as the exit",
    ),
    M(
        "wide-push-nearest-first",
        "kernels/intersect.h",
        "    keys = sort_keys_decreasing(keys);\n",
        "    keys = farthest_first ? sort_keys_decreasing(keys) : ~sort_keys_decreasing(keys != (lanes_u)(0u) ? ~keys : keys);\n",
        "wide BVH visits the farthest child first (slower, same hits)",
    ),
    M(
        "barycentric-u-from-v0",
        "kernels/triangle.h",
        "*u = e1 * inv_det;",
        "*u = e0 * inv_det;",
        "triangle hit reports v0's barycentric as u (v1's)",
    ),
    M(
        "watertight-edge-2-ignored",
        "kernels/triangle.h",
        "((e0 < 0.0f) | (e1 < 0.0f) | (e2 < 0.0f)) &",
        "((e0 < 0.0f) | (e1 < 0.0f)) &",
        "inside test forgets one edge for one winding",
    ),
    M(
        "offset-dropped",
        "kernels/common.h",
        "float3 offset = d * n;",
        "float3 offset = 0.0f * d * n;",
        "secondary rays start on the surface (only the one-ulp nudge is left)",
    ),
    # ---- kernels/trace.cl, common.h: camera rays, filtering, records
    M(
        "image-upside-down",
        "kernels/trace.cl",
        "float sy = 1.0f - 2.0f * (py + off.y) / (float)height;",
        "float sy = 2.0f * (py + off.y) / (float)height - 1.0f;",
        "image rows flipped",
    ),
    M(
        "filter-not-normalised",
        "kernels/trace.cl",
        "colour_out[gid] = (float4)(sum / weight_sum, 1.0f);",
        "colour_out[gid] = (float4)(sum / (float)(n * n), 1.0f);",
        "pixel filter weights not normalised",
    ),
    M(
        "ids-of-second-sample",
        "kernels/trace.cl",
        "bool keep = record && s == 0;",
        "bool keep = record && s == 1;",
        "ids and shadows recorded from sample 1, i.e. never with one sample",
    ),
    M(
        "intersect-returns-prim-id",
        "kernels/trace.cl",
        "object_out[idx[k]] = h[k].id >= 0 ? prim_object[h[k].id] : -1;",
        "object_out[idx[k]] = h[k].id >= 0 ? h[k].id : -1;",
        "intersect query reports primitive ids as object ids",
    ),
    M(
        "block-sphere-slot-off-by-one",
        "kernels/intersect.h",
        "if (sl[k] < -1) test_slots(prims, -2 - sl[k], -1 - sl[k], r, t_min, best);",
        "if (sl[k] < -1) test_slots(prims, -1 - sl[k], -sl[k], r, t_min, best);",
        "a sphere in a leaf block is looked up one slot off",
    ),
    M(
        "block-last-skipped",
        "kernels/intersect.h",
        "for (int b = 0; b < count; b += BLOCK_LANES",
        "for (int b = 0; b + BLOCK_LANES < count; b += BLOCK_LANES",
        "closest hit skips the last block of a leaf",
    ),
    M(
        "pair-answers-first-ray",
        "kernels/trace.cl",
        "else h[k + j] = w[j].best.slot < 0 ? no_hit() : w[j].best;",
        "else h[k + j] = w[0].best.slot < 0 ? no_hit() : w[0].best;",
        "both rays of a work-item's pair get the first ray's hit",
    ),
    # ---- kernels/packet.h: eight rays walked as one packet
    M(
        "packet-shared-t-max",
        "kernels/packet.h",
        "t_exit = (lanes_f)(t_max.s##k);",
        "t_exit = (lanes_f)(t_max.s0);",
        "every ray of a packet culls boxes by the first ray's nearest hit",
        PACKET,
    ),
    M(
        "packet-ties-to-higher-id",
        "kernels/packet.h",
        "((t == p->t_max) & (id < p->id))",
        "((t == p->t_max) & (id > p->id))",
        "a packet's ties at equal t go to the higher primitive id",
        PACKET,
    ),
    M(
        "packet-one-blocked-blocks-all",
        "kernels/packet.h",
        "p->live &= ~ray_bits(hit);",
        "p->live = 0;",
        "one blocked shadow ray of a packet blocks all eight",
        PACKET,
    ),
    M(
        "packet-culls-too-near",
        "kernels/packet.h",
        "ray_bits((float8)(key_t(key)) <= p->t_max * 1.0000004f)",
        "ray_bits((float8)(key_t(key)) <= p->t_max * 0.5f)",
        "a packet drops boxes nearer than a ray's nearest hit",
        PACKET,
    ),
    M(
        "packet-mixed-axes",
        "kernels/packet.h",
        "if (r[k].kz != r[0].kz) return false;",
        "if (0) return false;",
        "rays whose directions' largest axes differ share one triangle-test permutation",
        PACKET,
    ),
    M(
        "packet-signs-unchecked",
        "kernels/trace.cl",
        "if ((s.x != signs.x) | (s.y != signs.y) | (s.z != signs.z)) return false;",
        "if ((s.x != signs.x) & 0) return false;",
        "rays whose directions' signs differ walk as one packet (one near plane for all)",
        PACKET,
    ),
    M(
        "packet-last-lane-skipped",
        "kernels/packet.h",
        "for (int k = 0; k < BLOCK_LANES; ++k) {",
        "for (int k = 0; k < BLOCK_LANES - 1; ++k) {",
        "a packet skips the last triangle of every leaf block",
        PACKET,
    ),
    M(
        "packet-pushes-lane-0-rays",
        "kernels/packet.h",
        "p->stack_rays[sp + j] = (uchar)r[key_lane(k[j], farthest_first)];",
        "p->stack_rays[sp + j] = (uchar)r[0];",
        "a packet's sorted lanes carry the rays that hit lane 0",
        PACKET,
    ),
    M(
        "packet-sphere-skipped",
        "kernels/packet.h",
        "packet_sphere(p, prims, -2 - slot, rays, any_hit);",
        "packet_sphere(p, prims, -1 - slot, rays, any_hit);",
        "a packet tests the slot after a leaf block's sphere instead of the sphere",
        PACKET,
    ),
    M(
        "packet-sphere-blocks-ray-0",
        "kernels/packet.h",
        "== 0.0f) p->live &= ~(1u << k);",
        "== 0.0f) p->live &= ~1u;",
        "a sphere blocking any shadow ray of a packet blocks its first ray instead",
        PACKET,
    ),
    M(
        "packet-answers-first-ray",
        "kernels/trace.cl",
        "h[k].t = t[k]; h[k].id = id[k];",
        "h[k].t = t[0]; h[k].id = id[k];",
        "every ray of a packet gets the first ray's distance",
        PACKET,
    ),
    M(
        "key-distance-rounded-up",
        "kernels/intersect.h",
        "INLINE float key_t(uint key) { return as_float((key - 1u) & ~LANE_MASK); }",
        "INLINE float key_t(uint key) { return as_float(((key - 1u) | LANE_MASK) + 64u); }",
        "a stacked lane's distance is read too large, so boxes holding the nearest hit are culled",
    ),
    M(
        "cross-sign",
        "kernels/common.h",
        "return (float3)(a.y * b.z - a.z * b.y,",
        "return (float3)(a.z * b.y - a.y * b.z,",
        "first component of the cross product negated",
    ),
    M("inv-d-wrong", "kernels/common.h", "r.inv_d = (float3)(1.0f) / d;", "r.inv_d = d;", "slab test uses d instead of 1/d"),
    # ---- kernels/sampling.h, rng.h: where samples fall
    M(
        "sobol-same-scramble",
        "kernels/sampling.h",
        "uint key = hash4(rng->seed, rng->pixel, 0x50B01U, 0U);",
        "uint key = hash4(rng->seed, 0U, 0x50B01U, 0U);",
        "Sobol scrambling the same for every pixel",
        SAMPLING,
    ),
    M(
        "tent-wrong-width",
        "kernels/sampling.h",
        "(1.0f - 2.0f * fabs(dx)) * (1.0f - 2.0f * fabs(dy))",
        "(1.0f - fabs(dx)) * (1.0f - fabs(dy))",
        "tent filter twice as wide",
        SAMPLING,
    ),
    M(
        "gaussian-filter-sigma",
        "kernels/sampling.h",
        "/ (2.0f * 0.25f * 0.25f)",
        "/ (0.25f * 0.25f)",
        "Gaussian pixel filter with sigma 0.177 instead of 0.25",
        SAMPLING,
    ),
    M(
        "stratified-p-q-swapped",
        "kernels/sampling.h",
        "return (float2)((q + x) / fn, (p + y) / fn);",
        "return (float2)((p + x) / fn, (q + y) / fn);",
        "stratified sample s in the transposed sub-square",
        SAMPLING,
    ),
    M(
        "uniform-grid-transposed",
        "kernels/sampling.h",
        "return (float2)((q + 0.5f) / fn, (p + 0.5f) / fn);",
        "return (float2)((p + 0.5f) / fn, (q + 0.5f) / fn);",
        "the seed's uniform grid transposed",
        SAMPLING,
    ),
    M(
        "sobol-direction-numbers",
        "kernels/sampling.h",
        "v ^= v >> 1)",
        "v ^= v >> 2)",
        "wrong direction numbers for Sobol's second dimension",
        SAMPLING,
    ),
    M(
        "owen-odd-multiplier",
        "kernels/sampling.h",
        "x ^= x * 0x6c50b47cU;",
        "x ^= x * 0x6c50b47dU;",
        "an odd multiplier in the Laine-Karras hash (breaks nested scrambling)",
        SAMPLING,
    ),
    M(
        "area-light-xi-swapped",
        "kernels/shade.h",
        "(fp + xi_a) / fn : xi_a;\n                light_f ub = sc->light_stratified ? (fq + xi_b) / fn : xi_b;",
        "(fp + xi_b) / fn : xi_a;\n                light_f ub = sc->light_stratified ? (fq + xi_a) / fn : xi_b;",
        "area-light jitters used in the other order",
    ),
    M(
        "area-light-cells-off-by-one",
        "kernels/shade.h",
        "(fp + xi_a) / fn : xi_a;",
        "(fp + xi_a) / (fn + 1.0f) : xi_a;",
        "area-light strata cover n/(n+1) of edge a",
    ),
    M("u01-scale", "kernels/rng.h", "(1.0f / 16777216.0f)", "(1.0f / 8388608.0f)", "uniform numbers in [0, 2) instead of [0, 1)", SAMPLING),
    M(
        "hash-ignores-sample",
        "kernels/rng.h",
        "h = mix32(h ^ (c + 0xc2b2ae35U));",
        "h = mix32(h ^ (0U + 0xc2b2ae35U));",
        "every sample of a pixel draws the same random numbers",
        SAMPLING,
    ),
    M("mix32-constant", "kernels/rng.h", "x *= 0x7feb352dU;", "x *= 0x7feb352cU;", "a different (even, weaker) multiplier in lowbias32", SAMPLING),
    # ---- kernels/splat_gauss.cl
    M(
        "splat-offdiag-sign",
        "kernels/splat_gauss.cl",
        "-2.0f * sxy / det",
        "2.0f * sxy / det",
        "Gaussian's off-diagonal term negated (ellipses mirrored)",
        SPLAT,
    ),
    M(
        "splat-luminance-dropped",
        "kernels/splat_gauss.cl",
        "(float4)(p[5] * p[8], p[6] * p[8],",
        "(float4)(p[5], p[6] * p[8],",
        "red channel ignores the luminance factor",
        SPLAT,
    ),
    M(
        "splat-normalized-no-background",
        "kernels/splat_gauss.cl",
        "R = (R + EPS * background.x) * n;",
        "R = R * n;",
        "normalized blend drops the background term in red",
        SPLAT,
    ),
    M(
        "splat-grad-mx-sign",
        "kernels/splat_gauss.cl",
        "gmx -= dLdq * (2.0f * s.s2 * dx + s.s3 * dy);",
        "gmx += dLdq * (2.0f * s.s2 * dx + s.s3 * dy);",
        "gradient of the centre's x negated",
        SPLAT,
    ),
    M(
        "splat-grad-B",
        "kernels/splat_gauss.cl",
        "gB += dLdq * dx * dy;",
        "gB += dLdq * dx * dx;",
        "gradient of the off-diagonal term uses dx^2",
        SPLAT,
    ),
    M("splat-cutoff", "kernels/splat_gauss.cl", "#define CUTOFF_Q 9.0f", "#define CUTOFF_Q 4.0f", "splats cut at 2 sigma instead of 3", SPLAT),
    # ---- kernels/splat_voronoi.cl
    M(
        "voronoi-naive-tie",
        "kernels/splat_voronoi.cl",
        "if (d2 < best_d2) {",
        "if (d2 <= best_d2) {",
        "naive search gives ties to the higher index",
        VORONOI,
    ),
    M(
        "voronoi-grid-stops-early",
        "kernels/splat_voronoi.cl",
        "if (all(gap * gap > best_d2))",
        "if (all(gap * gap > 0.25f * best_d2))",
        "grid search stops before the nearest site is certain",
        VORONOI,
    ),
    M(
        "voronoi-softmax-sign",
        "kernels/splat_voronoi.cl",
        "w[j] = exp(-(bd[j] - bd[0]) * inv_temp);",
        "w[j] = exp((bd[j] - bd[0]) * inv_temp);",
        "soft Voronoi favours far sites",
        VORONOI,
    ),
    M(
        "voronoi-d2",
        "kernels/splat_voronoi.cl",
        "return dx * dx + dy * dy;",
        "return dx * dx + dx * dy;",
        "squared distance with dx dy for dy^2",
        VORONOI,
    ),
    # ---- host packing: geometry, tracer, lights, materials, camera, renderer
    M(
        "pack-first-vertex",
        "clrender/trace/geometry.py",
        "out[is_tri, 0, :3] = t[:, 0]",
        "out[is_tri, 0, :3] = t[:, 1]",
        "triangle record starts at the wrong vertex",
    ),
    M("pack-sphere-flag", "clrender/trace/geometry.py", "out[~is_tri, 1, 3] = 1.0", "out[~is_tri, 1, 3] = 0.0", "spheres packed as triangles"),
    M(
        "pack-smooth-flag",
        "clrender/trace/geometry.py",
        "objects[oid, 1] = int(obj.smooth and obj.vertex_normals is not None)",
        "objects[oid, 1] = 0",
        "host never marks a mesh smooth",
    ),
    M(
        "bounds-not-widened",
        "clrender/trace/geometry.py",
        "return np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)",
        "return lo, hi",
        "float32 primitive bounds not widened by an ulp",
    ),
    M(
        "pack-normals-reversed",
        "clrender/trace/tracer.py",
        "= self.primitives.triangle_normals",
        "= self.primitives.triangle_normals[:, ::-1]",
        "vertex normals packed in reverse vertex order",
    ),
    M(
        "light-intensity-dropped",
        "clrender/scene/lights.py",
        "self.samples, self.intensity, FALLOFFS[self.falloff]",
        "self.samples, 1.0, FALLOFFS[self.falloff]",
        "light intensity not packed",
    ),
    M(
        "light-directional-position",
        "clrender/scene/lights.py",
        'where = self.direction if self.type == "directional" else self.position',
        "where = self.position",
        "directional light packed with its (unused) position",
    ),
    M(
        "material-ior-dropped",
        "clrender/scene/materials.py",
        "[self.transparency, self.ior, 0, 0]",
        "[self.transparency, 1.0, 0, 0]",
        "IOR not packed (every material is air)",
    ),
    M(
        "material-mirror-dropped",
        "clrender/scene/materials.py",
        "[*self.specular, self.mirror]",
        "[*self.specular, 0.0]",
        "mirror fraction not packed",
    ),
    M("camera-aspect", "clrender/scene/camera.py", "half_w = half_h * width / height", "half_w = half_h", "camera ignores the aspect ratio"),
    M(
        "camera-right-flipped",
        "clrender/scene/camera.py",
        "right = np.cross(forward, np.asarray(self.up, np.float64))",
        "right = np.cross(np.asarray(self.up, np.float64), forward)",
        "image mirrored left to right",
    ),
    M(
        "light-sampler-flag-inverted",
        "clrender/trace/renderer.py",
        'np.int32(s.light_sampler == "stratified")',
        'np.int32(s.light_sampler != "stratified")',
        "--light-sampler stratified and random swapped",
    ),
    # ---- host I/O (the list first)
    M(
        "exr-srgb-encoded",
        "clrender/image/files.py",
        'return write_image(path, linear_rgb, format="float"',
        'return write_image(path, linear_to_srgb(linear_rgb), format="float"',
        "EXR written sRGB-encoded",
        OUTPUT,
    ),
    M(
        "png-not-encoded",
        "clrender/image/files.py",
        'return write_image(path, linear_to_srgb(linear_rgb), format="uint8"',
        'return write_image(path, linear_rgb, format="uint8"',
        "PNG written without sRGB encoding",
        OUTPUT,
    ),
    M(
        "srgb-gamma-2.2",
        "clrender/image/files.py",
        "return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)",
        "return (np.power(x, 1.0 / 2.2) + 0 * x)",
        "sRGB as a plain gamma 2.2 instead of the piecewise curve",
        OUTPUT,
    ),
    M(
        "srgb-toe-slope",
        "clrender/image/files.py",
        "x <= 0.0031308, 12.92 * x",
        "x <= 0.0031308, 12.0 * x",
        "sRGB linear toe with slope 12 instead of 12.92",
        OUTPUT,
    ),
    M(
        "srgb-inverse-exponent",
        "clrender/image/files.py",
        "np.power((x + 0.055) / 1.055, 2.4)",
        "np.power((x + 0.055) / 1.055, 2.2)",
        "inverse sRGB with exponent 2.2",
        OUTPUT,
    ),
]


# ------------------------------------------------------------------ the harness


def snapshot(dest: Path) -> int:
    """Copy the working tree (tracked + untracked-not-ignored files, as on disk) to dest."""
    listing = (
        subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT, capture_output=True, check=True)
        .stdout.decode()
        .split("\0")
    )
    count = 0
    for rel in filter(None, dict.fromkeys(listing)):
        src = ROOT / rel
        if not src.is_file():  # deleted in the working tree
            continue
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest / rel)
        count += 1
    return count


def occurrences(base: Path, m: Mutant) -> int:
    path = base / m.file
    return path.read_text().count(m.old) if path.is_file() else 0


def pytest_command(python: Path, tests, first_failure_stops=True, deselect=()) -> list:
    return [
        str(python),
        "-m",
        "pytest",
        *(["-x"] if first_failure_stops else []),
        "-q",
        "-rfE",
        "-m",
        "not slow",
        "-p",
        "no:cacheprovider",
        "-p",
        "no:randomly",
        *[f"--deselect={d}" for d in deselect],
        *tests,
    ]


def run_tests(python: Path, cwd: Path, tests, timeout: float, **options):
    """(return code or None on timeout, seconds, output) of the tests run in cwd."""
    # PYTHONPATH too, so tests that start `python -m clrender` in another folder also run the copy
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=str(cwd))
    start = time.perf_counter()
    proc = subprocess.Popen(
        pytest_command(python, tests, **options),
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        out, _ = proc.communicate(timeout=timeout)
        rc = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the test process and anything it started
        out, _ = proc.communicate()
        rc = None
    return rc, time.perf_counter() - start, out


def first_failure(output: str) -> str:
    m = re.search(r"^(?:FAILED|ERROR) (\S+)", output, re.M)
    if m:
        return m.group(1).split(" - ")[0]
    m = re.search(r"^E\s+(.{0,80})", output, re.M)
    return m.group(1).strip() if m else ""


def check_imports(python: Path, copy: Path) -> None:
    """The copy's clrender and kernels are the ones used when running from the copy."""
    code = "import clrender, clrender.device as d; print(clrender.__file__); print(d.kernel_dir())"
    elsewhere = copy.parent  # as a test that runs `python -m clrender` from a temporary folder
    env = dict(os.environ, PYTHONPATH=str(copy))
    out = subprocess.run([str(python), "-c", code], cwd=copy, capture_output=True, text=True, check=True).stdout
    out += subprocess.run([str(python), "-c", code], cwd=elsewhere, env=env, capture_output=True, text=True, check=True).stdout
    paths = [Path(line).resolve() for line in out.split()]
    if not all(copy.resolve() in p.parents for p in paths):
        raise SystemExit(f"mutants: running from {copy} imports {paths}, not the copy; cannot test mutants there")


def run_mutant(m: Mutant, base: Path, work: Path, python: Path, timeout: float, skip=(), deselect=()) -> dict:
    copy = work / m.id
    shutil.copytree(base, copy)
    try:
        target = copy / m.file
        text = target.read_text()
        target.write_text(text.replace(m.old, m.new, 1))
        tests = [t for t in m.tests if (copy / t).is_file() and t not in skip]
        if not tests:  # pytest with no file would run the whole suite
            return dict(id=m.id, file=m.file, what=m.what, status="error", seconds=0, detail="no test files")
        rc, seconds, out = run_tests(python, copy, tests, timeout, deselect=[d for d in deselect if d.split("::")[0] in tests])
    finally:
        shutil.rmtree(copy, ignore_errors=True)
    if rc is None:
        status, detail = "killed", f"timeout after {timeout:.0f} s"
    elif rc == 0:
        status, detail = "survived", f"{len(tests)} test files passed"
    elif rc == 5:
        status, detail = "error", "no tests collected"
    else:
        status, detail = "killed", first_failure(out) or f"pytest exit {rc}"
    return dict(id=m.id, file=m.file, what=m.what, status=status, seconds=round(seconds, 1), detail=detail)


def select(ids) -> list:
    if not ids:
        return list(MUTANTS)
    chosen = [m for m in MUTANTS if any(fnmatch.fnmatchcase(m.id, pattern) for pattern in ids)]
    unknown = [p for p in ids if not any(fnmatch.fnmatchcase(m.id, p) for m in MUTANTS)]
    if unknown:
        raise SystemExit(f"mutants: no mutant matches {', '.join(unknown)} (see --list)")
    return chosen


def markdown(rows) -> str:
    lines = ["| id | file | what it breaks | result | s | first failing test |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['id']} | {r['file']} | {r['what']} | {r['status']} | {r['seconds']} | {r['detail']} |" for r in rows]
    return "\n".join(lines)


def main(argv) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench mutants", description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--list", action="store_true", help="list the mutants and whether each still applies, then exit")
    parser.add_argument("--only", nargs="+", metavar="ID", help="run only these mutants (ids or fnmatch patterns)")
    parser.add_argument("--jobs", type=int, default=1, help="mutants run at the same time")
    parser.add_argument("--tests", nargs="+", metavar="FILE", help="run these test files for every chosen mutant instead of each mutant's own list")
    parser.add_argument("--timeout", type=float, default=900, help="seconds per mutant before it counts as killed")
    parser.add_argument(
        "--python",
        type=Path,
        default=DEFAULT_PYTHON if DEFAULT_PYTHON.exists() else Path(sys.executable),
        help="interpreter with pytest and the project's dependencies",
    )
    parser.add_argument("--no-baseline", action="store_true", help="skip running the unmutated tests first")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "out", help="folder for mutants.md and mutants.csv")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs} must be at least 1")
    ids = [m.id for m in MUTANTS]
    assert len(ids) == len(set(ids)), "duplicate mutant ids"
    chosen = select(args.only)
    if args.tests:
        from dataclasses import replace

        chosen = [replace(m, tests=tuple(args.tests)) for m in chosen]

    with tempfile.TemporaryDirectory(prefix="clrender-mutants-") as tmp:
        base, work = Path(tmp) / "base", Path(tmp) / "work"
        base.mkdir()
        work.mkdir()
        n_files = snapshot(base)
        counts = {m.id: occurrences(base, m) for m in chosen}
        if args.list:
            for m in chosen:
                state = "ok" if counts[m.id] == 1 else f"STALE (old snippet found {counts[m.id]} times)"
                print(f"{m.id:32s} {m.file:28s} {state:10s} {m.what}")
            print(f"{len(chosen)} mutants, {sum(c == 1 for c in counts.values())} apply; {len({m.file for m in MUTANTS})} files")
            return 0
        runnable = [m for m in chosen if counts[m.id] == 1]
        stale = [m for m in chosen if counts[m.id] != 1]
        for m in stale:
            print(f"STALE {m.id}: its old snippet occurs {counts[m.id]} times in {m.file}; not run", flush=True)
        print(f"snapshot of {n_files} files in {base}; {len(runnable)} mutants to run, {args.jobs} at a time", flush=True)
        check_imports(args.python, base)
        broken, failing = set(), []
        if not args.no_baseline:
            # a test that fails without any mutation would "kill" every mutant: deselect it (or
            # leave its whole file out when the file does not even run)
            tests = [t for t in dict.fromkeys(t for m in runnable for t in m.tests) if (base / t).is_file()]
            start = time.perf_counter()
            for t in tests:
                rc, seconds, out = run_tests(args.python, base, [t], args.timeout, first_failure_stops=False)
                if rc == 0:
                    continue
                ids = re.findall(r"^FAILED (\S+)", out, re.M)
                if rc == 1 and ids and not re.search(r"^ERROR ", out, re.M):
                    failing += ids
                    print(f"BASELINE FAILS {len(ids)} test(s) of {t} (e.g. {ids[0]}): deselected for every mutant", flush=True)
                else:
                    broken.add(t)
                    print(f"BASELINE FAILS {t} (exit {rc}, {first_failure(out)}): left out of every mutant's run", flush=True)
            print(
                f"baseline (no mutation): {len(tests) - len(broken)} of {len(tests)} test files run, "
                f"{len(failing)} failing tests deselected, {time.perf_counter() - start:.0f} s",
                flush=True,
            )

        rows = []

        def one(m):
            row = run_mutant(m, base, work, args.python, args.timeout, broken, failing)
            print(f"{row['status']:9s} {m.id:32s} {row['seconds']:6.1f} s  {row['detail']}", flush=True)
            return row

        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            rows = list(pool.map(one, runnable))
    rows += [dict(id=m.id, file=m.file, what=m.what, status="stale", seconds=0, detail=f"old snippet found {counts[m.id]} times") for m in stale]
    order = {m.id: i for i, m in enumerate(MUTANTS)}
    rows.sort(key=lambda r: order[r["id"]])
    killed = sum(r["status"] == "killed" for r in rows)
    ran = sum(r["status"] in ("killed", "survived") for r in rows)
    left_out = sorted(broken) + failing
    summary = (("baseline failures left out: " + ", ".join(left_out) + "\n\n") if left_out else "") + (
        f"{killed} of {ran} mutants killed ({100 * killed / max(ran, 1):.0f}%), "
        f"{sum(r['status'] == 'survived' for r in rows)} survived, {len(stale)} stale, "
        f"{sum(r['status'] == 'error' for r in rows)} errors"
    )
    table = markdown(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "mutants.md").write_text(f"# Mutants\n\n{summary}\n\n{table}\n")
    import csv

    with open(args.out / "mutants.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]) if rows else ["id"])
        writer.writeheader()
        writer.writerows(rows)
    print(table)
    print(summary)
    return 0
