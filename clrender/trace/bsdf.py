"""The BSDF lobes of kernels/bsdf.h, evaluated and sampled on the device in batches (kernels/bsdf_probe.cl), through
the dispatch the path tracer calls (component_eval, component_pdf, component_sample).

For tests, the path tracer's tests among them.  Directions are in the local shading frame (normal +z) and
both point away from the surface: wo to the viewer, wi to the light.  As in the kernels:
  eval(wo, wi)   f(wo, wi) * |cos theta_i|, RGB
  pdf(wo, wi)    solid-angle density of sample's wi (0 where the sampler cannot go)
  sample(wo, u)  wi, weight = eval / pdf (0 for a failed sample), pdf, delta (a delta lobe's branch:
                 pdf is then that branch's probability)
Lobes and their parameters (`params`):
  lambert           colour = albedo
  conductor         colour = Schlick F0, alpha = GGX width
  dielectric        eta = IOR inside (-z) / outside (+z); smooth: delta lobes, eval and pdf are 0
  rough_dielectric  eta, alpha
  gltf              colour = base colour, metallic, alpha = roughness^2 (gltf_params converts)
  mirror            colour = reflectance; a delta, eval and pdf are 0
  phong             colour = kd, tint = ks, alpha = the glossy lobe's GGX width, specular_prob (phong_params computes
                    them as the kernel's Phong material does)
and the lobes of kernels/bsdf_exchange.h (issue 36):
  metal, metal_smooth      eta3, k3 (complex IOR per channel), tint, alpha
  coated_diffuse(_smooth)  colour = diffuse base, eta = coat IOR, tint, alpha, nonlinear, coat_weight,
                           coat_internal, coat_transmittance (coated_params computes them as scenes do)
  thin_dielectric          eta, tint, transmit_tint
Every GGX lobe takes smith: 0 height-correlated, 1 separable.  A dielectric's transmission (rough or smooth) is
multiplied by transmit_tint.
"""

from __future__ import annotations

import math

import numpy as np
import pyopencl as cl

from ..device import Device, kernel_source
from ..launch import Kernel, kernel_signatures
from ..layout import BSDF_LOBES as LOBES
from ..layout import BSDF_PROBE_DTYPE
from .tracer import trace_defines
from .work_layout import launch_items

LUMINANCE = (0.2126, 0.7152, 0.0722)  # kernels/material.h's luminance(): the Phong lobe's sampling split
PARAM_FLOATS = BSDF_PROBE_DTYPE.itemsize // 4  # a BsdfProbeParams record as float32s (layout.BSDF_PROBE_DTYPE)
LOBE_FIELD = BSDF_PROBE_DTYPE.fields["lobe"][1] // 4  # the record's lobe code, as a float32 column
PROBE = "bsdf_probe.cl"


def bsdf_defines() -> dict:
    """The -D variant of kernels/bsdf_probe.cl: common.h's traversal knobs."""
    return trace_defines()


def params(colour=(1.0, 1.0, 1.0), alpha=0.5, eta=1.5, metallic=0.0, **more) -> np.ndarray:
    """Parameter records, (n, PARAM_FLOATS) float32, broadcast over any array arguments (colour: (..., 3)).  `more`:
    the other BsdfProbeParams fields by name (smith, eta3, k3, tint, transmit_tint, nonlinear, coat_*); tint and
    transmit_tint default to 1."""
    values = {"colour": colour, "alpha": alpha, "eta": eta, "metallic": metallic, "tint": (1.0, 1.0, 1.0), "transmit_tint": (1.0, 1.0, 1.0)}
    values.update(more)
    arrays = {name: np.asarray(v, np.float64) for name, v in values.items()}
    field_shape = lambda name: BSDF_PROBE_DTYPE.fields[name][0].shape
    shape = np.broadcast_shapes(*(a.shape[: a.ndim - len(field_shape(name))] for name, a in arrays.items()))
    out = np.zeros(shape, BSDF_PROBE_DTYPE)
    for name, a in arrays.items():
        out[name] = a
    return out.reshape(-1).view(np.float32).reshape(-1, PARAM_FLOATS)


def gltf_params(base_colour=(1.0, 1.0, 1.0), metallic=0.0, roughness=0.5) -> np.ndarray:
    """A glTF metallic-roughness record: alpha = roughness^2 (the glTF / Disney convention)."""
    return params(colour=base_colour, alpha=np.square(np.asarray(roughness, np.float64)), metallic=metallic)


def phong_params(diffuse=(0.5, 0.5, 0.5), specular=(0.3, 0.3, 0.3), shininess=20.0) -> np.ndarray:
    """A Phong material's lobe as kernels/material.h picks it: kd and ks (scaled together where kd + ks exceeds 1),
    the glossy lobe's GGX width sqrt(2 / (shininess + 2)) and its sampling probability lum(ks) / (lum(ks) + lum(kd))."""
    kd, ks = np.asarray(diffuse, np.float32), np.asarray(specular, np.float32)
    over = max(1.0, float(np.max(kd + ks)))
    kd, ks = kd / np.float32(over), ks / np.float32(over)
    luminance = lambda c: float(np.dot(LUMINANCE, c))
    alpha = max(math.sqrt(2.0 / (shininess + 2.0)), 1e-4)
    return params(colour=kd, tint=ks, alpha=alpha, specular_prob=luminance(ks) / (luminance(ks) + luminance(kd)))


def coated_params(diffuse=(0.5, 0.5, 0.5), ior=1.5, roughness=0.0, tint=(1.0, 1.0, 1.0), nonlinear=False, smith="correlated"):
    """A coated diffuse's record as a scene's `type = "coated_diffuse"` material packs it (scene/coat.py's tables)."""
    from ..scene.materials import Material  # the scene's packing: the weight, internal reflectance and table

    m = Material(kind="coated_diffuse", diffuse=tuple(diffuse), lobe_ior=ior, roughness=roughness, tint=tuple(tint), nonlinear=nonlinear, smith=smith)
    return params(
        colour=diffuse,
        alpha=max(np.float32(roughness) ** 2, 1e-4),
        eta=ior,
        tint=tint,
        smith=m.smith_code,
        nonlinear=float(nonlinear),
        coat_weight=m.coat_weight,
        coat_internal=m.coat_internal,
        coat_transmittance=m.coat_transmittance,
    )


def _rows(v) -> np.ndarray:
    """(k, 4) float32 rows of (k, 3) or (3,) vectors."""
    v = np.asarray(v, np.float32).reshape(-1, 3)
    out = np.zeros((len(v), 4), np.float32)
    out[:, :3] = v
    return out


class BsdfProbe:
    """The probe kernels of one program: the device's cached build of kernels/bsdf_probe.cl, or `program`
    (a build of a modified copy, as the tests' planted bugs use).  `lanes`: items a work-item, each in one lane of a
    vector (kernels/lanes.h: 1, as the path tracer runs the lobes, 8 or 16), which give the same bits."""

    def __init__(self, device: Device, program: cl.Program | None = None, lanes: int = 1):
        self.device, self.lanes = device, lanes
        if program is None:  # the device's cached kernels
            fetch = lambda name: device.kernel(PROBE, name, {**bsdf_defines(), "LANES": lanes})
        else:
            signatures = kernel_signatures(kernel_source(PROBE))
            fetch = lambda name: Kernel(cl.Kernel(program, name), signatures[name])
        self._eval, self._pdf, self._sample = fetch("bsdf_eval_probe"), fetch("bsdf_pdf_probe"), fetch("bsdf_sample_probe")
        self._frame = fetch("frame_probe")

    def _common(self, lobe: str | None, records, wo, n: int):
        records = np.array(records, np.float32).reshape(-1, PARAM_FLOATS)
        if lobe is not None:  # None: each record's own code (params(lobe=codes)), a batch of mixed lobes
            records[:, LOBE_FIELD] = LOBES[lobe]
        wo_rows = _rows(wo)
        for name, k in (("params", len(records)), ("wo", len(wo_rows))):
            if k not in (1, n):
                raise ValueError(f"{name} has {k} rows; expected 1 or {n}")
        dev = self.device
        return dict(
            n=n,
            params=dev.to_device(records),
            params_stride=int(len(records) > 1 or n == 1),
            wo=dev.to_device(wo_rows),
            wo_stride=int(len(wo_rows) > 1 or n == 1),
        )

    def _run(self, knl, n: int, args: dict, outputs: dict):
        """Launch with `args` and one new buffer per name of `outputs` (name -> shape); the outputs, in order."""
        dev = self.device
        outs = {name: dev.empty(4 * int(np.prod(shape))) for name, shape in outputs.items()}
        launch_items(dev, knl, -(-n // self.lanes), **args, **outs)
        results = []
        for buf, shape in zip(outs.values(), outputs.values()):
            host = np.empty(shape, np.float32)
            cl.enqueue_copy(dev.queue, host, buf)
            results.append(host)
        return results

    def eval(self, lobe: str | None, records, wo, wi) -> np.ndarray:
        """(n, 3) f * |cos theta_i| for wi (n, 3), wo (n, 3) or (3,), records (n or 1, PARAM_FLOATS)."""
        wi_rows = _rows(wi)
        n = len(wi_rows)
        (out,) = self._run(self._eval, n, {**self._common(lobe, records, wo, n), "wi": self.device.to_device(wi_rows)}, {"out": (n, 4)})
        return out[:, :3]

    def pdf(self, lobe: str | None, records, wo, wi) -> np.ndarray:
        """(n,) solid-angle pdf of wi given wo."""
        wi_rows = _rows(wi)
        n = len(wi_rows)
        (out,) = self._run(self._pdf, n, {**self._common(lobe, records, wo, n), "wi": self.device.to_device(wi_rows)}, {"out": (n,)})
        return out

    def sample(self, lobe: str | None, records, wo, u):
        """wi (n, 3), weight (n, 3), pdf (n,), delta (n,) bool for u (n, 3) in [0, 1): (u1, u2.x, u2.y)."""
        u = np.asarray(u, np.float32).reshape(-1, 3)
        n = len(u)
        args = {**self._common(lobe, records, wo, n), "u": self.device.to_device(_rows(u))}
        wi, wp = self._run(self._sample, n, args, {"wi_out": (n, 4), "weight_out": (n, 4)})
        return wi[:, :3], wp[:, :3], wp[:, 3], wi[:, 3] != 0

    def frame(self, normals, v):
        """The kernel's shading frame of each unit normal: (n, 3, 3) rows t, b, n; v in it; and back in the world."""
        normals, v = _rows(normals), _rows(v)
        n = len(normals)
        dev = self.device
        args = dict(n=n, normals=dev.to_device(normals), v=dev.to_device(v))
        frames, local, back = self._run(self._frame, n, args, {"out": (n, 3, 4), "in_frame": (n, 4), "back": (n, 4)})
        return frames[..., :3], local[:, :3], back[:, :3]


def eval(device: Device, lobe: str, records, wo, wi) -> np.ndarray:
    """BsdfProbe(device).eval: (n, 3) f * |cos theta_i|."""
    return BsdfProbe(device).eval(lobe, records, wo, wi)


def pdf(device: Device, lobe: str, records, wo, wi) -> np.ndarray:
    """BsdfProbe(device).pdf: (n,) solid-angle density."""
    return BsdfProbe(device).pdf(lobe, records, wo, wi)


def sample(device: Device, lobe: str, records, wo, u):
    """BsdfProbe(device).sample: wi, weight, pdf, delta."""
    return BsdfProbe(device).sample(lobe, records, wo, u)
