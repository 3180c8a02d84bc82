"""clrender: a Whitted ray tracer, convolution filters and image splatting on OpenCL."""

import os
import sys

if os.path.basename(sys.argv[0] if sys.argv else "") in ("clrender", "clrender.exe", "-m", "__main__.py"):
    # Run as the `clrender` program (console script, python -m): from this first line on, Ctrl-C or
    # SIGTERM ends it with one line and no traceback; clrender/cli.py takes over in main().
    # Nothing has been written this early, so leaving at once is safe.
    import _signal

    def _interrupted_while_starting(signum, frame):
        os.write(2, b"clrender: interrupted\n" if signum == _signal.SIGINT else b"clrender: terminated\n")
        os._exit(128 + signum)

    if _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
        _signal.signal(_signal.SIGINT, _interrupted_while_starting)
        _signal.siginterrupt(_signal.SIGINT, False)
    if _signal.getsignal(_signal.SIGTERM) == _signal.SIG_DFL:
        _signal.signal(_signal.SIGTERM, _interrupted_while_starting)
        _signal.siginterrupt(_signal.SIGTERM, False)

__version__ = "0.1.0"

# Imported on first use (PEP 562), so `import clrender.cli` is light and the
# command line can take over Ctrl-C before numpy and pyopencl load.
_EXPORTS = {  # the public API, by the module that defines it (README: code map)
    "Renderer": "trace.renderer",
    "RenderResult": "trace.renderer",
    "RenderSettings": "trace.renderer",
    "render": "trace.renderer",
    "Tracer": "trace.tracer",
    "edge_mask": "trace.edges",
    "build_bvh": "trace.bvh",
    "Scene": "scene.scene",
    "Camera": "scene.camera",
    "Light": "scene.lights",
    "Material": "scene.materials",
    "read_image": "image.files",
    "write_image": "image.files",
    "show": "image.display",
    "DisplaySettings": "image.tonemap",
    "denoise": "image.denoise",
    "get_device": "device",
    "list_devices": "device",
    "UsageError": "errors",
    "RenderFailure": "errors",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        from importlib import import_module

        value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    return _submodule(__name__, name)


def _submodule(package: str, name: str):
    """`package.name` imported on first attribute access, so `clrender.image.denoise.denoise_result(...)`
    works after a plain `import clrender`, as the docs write it (each subpackage's __getattr__ calls this)."""
    from importlib import import_module
    from importlib.util import find_spec

    if not name.startswith("_") and find_spec(f"{package}.{name}") is not None:
        return import_module(f"{package}.{name}")
    raise AttributeError(f"module {package!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
