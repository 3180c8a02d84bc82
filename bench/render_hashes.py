"""SHA-256 of every bundled scene's render in each AA mode, for checking that a refactor changed no pixel.

    python bench/render_hashes.py > after.txt      # in this checkout
    (cd OLD_CHECKOUT && python /path/to/bench/render_hashes.py) > before.txt
    diff before.txt after.txt

The clrender imported is the one of the current folder's checkout (run it from the repository root).
"""

import hashlib
import sys
from pathlib import Path

sys.path.insert(0, str(Path.cwd()))  # the checkout being measured, not an installed clrender

import clrender  # noqa: E402
from clrender import Renderer  # noqa: E402

SCENES = ("refract1", "refract2", "bunny", "wizard_cat", "wizard_hat", "wizard_tower")
AA_MODES = ("none", "full", "edge_detect")


def main() -> None:
    print(f"# clrender from {Path(clrender.__file__).parent}", file=sys.stderr)
    for scene in SCENES:
        for aa in AA_MODES:
            result = Renderer(scene, width=120, height=90, aa=aa, samples=1 if aa == "none" else 2, seed=7).run()
            digest = hashlib.sha256(result.image.tobytes() + result.ids.tobytes()).hexdigest()
            print(f"{scene:14s} {aa:12s} {digest}")


if __name__ == "__main__":
    main()
