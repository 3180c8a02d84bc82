"""clrender: a Whitted ray tracer, convolution filters and image splatting on OpenCL."""
import os

# numpy's OpenBLAS threads spin-wait after a matrix product and steal the
# cores PoCL runs the kernels on; clrender's host work never needs them.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"

# Imported on first use (PEP 562), so `import clrender.cli` is light and the
# command line can take over Ctrl-C before numpy and pyopencl load.
_EXPORTS = {
    "Renderer": "renderer", "RenderResult": "renderer", "RenderSettings": "renderer", "render": "renderer",
    "Scene": "scene", "Tracer": "tracer", "show": "display",
}
__all__ = ["Renderer", "RenderResult", "RenderSettings", "Scene", "Tracer", "render", "show"]


def __getattr__(name):
    if name in _EXPORTS:
        from importlib import import_module

        value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
