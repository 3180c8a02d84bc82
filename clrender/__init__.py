"""clrender: a Whitted ray tracer, convolution filters and image splatting on OpenCL."""
import os

# numpy's OpenBLAS threads spin-wait after a matrix product and steal the
# cores PoCL runs the kernels on; clrender's host work never needs them.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"

from .renderer import Renderer, RenderResult, RenderSettings, render  # noqa: E402
from .scene import Scene  # noqa: E402
from .tracer import Tracer  # noqa: E402

__all__ = ["Renderer", "RenderResult", "RenderSettings", "Scene", "Tracer", "render"]
