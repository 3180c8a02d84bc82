"""Where the kernel sources and bundled scenes live.

In a wheel they are the subpackages `clrender.kernels` and `clrender.scenes`
(setup.cfg maps the top-level folders there). Run from a source checkout (for
example `python -m pytest` at the repository root after a non-editable
`pip install .`), Python imports the checkout's `clrender/`, which has no such
subpackages; the top-level `kernels/` and `scenes/` beside it are then the
ones that belong to the code being run.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

_CHECKOUT = Path(__file__).resolve().parent.parent


def data_dir(name: str) -> Path:
    """Folder of the package data `name` ("kernels" or "scenes")."""
    beside_source = _CHECKOUT / name
    if (_CHECKOUT / "setup.cfg").is_file() and beside_source.is_dir():
        return beside_source
    return Path(str(resources.files(f"clrender.{name}")))
