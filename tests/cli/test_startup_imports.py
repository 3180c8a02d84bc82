"""A render's start-up leaves out the heavy modules it does not use:
trimesh (and scipy with it, 0.34 s) for a scene of generated meshes, OpenCV without --filter."""

import subprocess
import sys

SCRIPT = """
import sys
from clrender import cli  # noqa: F401 - what `clrender render` imports before it parses
from clrender.commands import convolve, render  # noqa: F401
from clrender.scene.scene import Scene
scene = Scene.load("wizard_cat")  # a cat, a hat and a tower from clrender.scene.meshes
assert sum(len(getattr(o, "faces", ())) for o in scene.objects) > 1000
print(" ".join(m for m in ("trimesh", "scipy", "cv2") if m in sys.modules))
"""


def test_generated_meshes_and_the_cli_import_neither_trimesh_nor_opencv():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
