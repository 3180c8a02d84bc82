"""Other renderers' sampler types, as the path tracer's samplers (RenderSettings.path_sampler; docs/materials.md,
"The sampler"): read by the Mitsuba and pbrt readers."""

from __future__ import annotations


def path_sampler_of(kind: str) -> str:
    """RenderSettings.path_sampler for a Mitsuba or pbrt sampler type: "independent" for theirs, "sobol" for every
    stratified or low-discrepancy one (Mitsuba's stratified, multijitter, orthogonal, ldsampler; pbrt's stratified,
    halton, sobol, zsobol, paddedsobol, pmj02bn): each stratifies every dimension, as clrender's Sobol sampler does."""
    return "independent" if kind == "independent" else "sobol"
