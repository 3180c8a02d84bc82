# %% [markdown]
# # Anti-aliasing modes side by side
#
# Renders the seed's edge-AA view of `wizard_cat` with each `--aa` mode, shows the edge mask that
# edge-only AA resampled, and puts the three renders next to each other with a zoomed crop.
#
# Open it as a notebook (VS Code and PyCharm read the `# %%` cells; Jupyter through jupytext) or
# run it as a script: `python examples/aa_modes.py [WIDTH [OUT.png]]` writes the comparison to
# `examples/out/aa_modes.png` (or OUT.png) and prints its path.

# %%
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import clrender
from clrender.image.files import linear_to_srgb
from clrender.image.plot import save

SCENE, CAMERA = "wizard_cat", 3  # the seed's edge-AA run: camera 3, stratified 4x4 here
args = [a for a in sys.argv[1:] if not a.startswith("-")]  # a notebook kernel passes -f FILE
WIDTH = int(args[0]) if args and args[0].isdigit() else 320
OUT = Path(args[1]) if len(args) > 1 else Path(__file__).resolve().parent / "out" / "aa_modes.png"

# %% One render per mode, sharing one scene and BVH. The last expression of a cell shows a
# RenderResult as its image.
scene = clrender.Scene.load(SCENE)
tracer = clrender.Tracer(scene)
results, seconds = {}, {}
for aa in ("none", "full", "edge_detect"):
    samples = 1 if aa == "none" else 4  # 4 x 4 stratified samples where a pixel is anti-aliased
    renderer = clrender.Renderer(scene, camera=CAMERA, width=WIDTH, aa=aa, sampler="stratified", samples=samples, tracer=tracer)
    results[aa] = renderer.run()
    seconds[aa] = sum(results[aa].timings.get(k, 0.0) for k in ("trace", "edges", "resample"))  # no compile
results["edge_detect"]

# %% The pixels edge-only AA traced again: object ids along each path, flat faces, shadows, colour steps.
edges = results["edge_detect"].edge_mask
print(f"{100 * edges.mean():.1f}% of the pixels resampled")
if "ipykernel" in sys.modules:
    clrender.show(edges)


# %% Side by side, each with its time and its RMSE against full AA, and a 4x crop below.
def rmse(a, b):
    return float(np.sqrt(np.mean((linear_to_srgb(a) - linear_to_srgb(b)) ** 2)))


reference = results["full"].image
h, w = reference.shape[:2]
crop = (slice(int(0.1 * h), int(0.35 * h)), slice(int(0.18 * w), int(0.43 * w)))  # the hat and its brim
panels = [
    (f"--aa {aa}: {seconds[aa]:.2f} s, " + (f"RMSE {rmse(r.image, reference):.4f}" if aa != "full" else "the reference"), linear_to_srgb(r.image))
    for aa, r in results.items()
]
panels.append((f"edge mask: {100 * edges.mean():.1f}% of pixels", edges.astype(np.float32)))
fig = Figure(figsize=(14, 7), layout="constrained")
axes = fig.subplots(2, 4)
for column, (title, image) in enumerate(panels):
    grey = "gray" if image.ndim == 2 else None
    axes[0, column].imshow(np.clip(image, 0, 1), cmap=grey, vmin=0, vmax=1, interpolation="nearest")
    axes[0, column].set_title(title, fontsize=9)
    axes[1, column].imshow(np.clip(image[crop], 0, 1), cmap=grey, vmin=0, vmax=1, interpolation="nearest")
for ax in axes.ravel():
    ax.set_axis_off()
fig.suptitle(f"{SCENE}, camera {CAMERA}, {w}x{h}, stratified 4x4")
print(save(OUT, fig))
fig  # noqa: B018 - a notebook shows the figure
