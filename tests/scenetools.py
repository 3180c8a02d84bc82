"""Scenes and files that several test folders build: copies of one mesh file (instancing), an alpha checker
texture (alpha testing)."""

import numpy as np
import trimesh

from clrender.scene.scene import Scene

CHECKER = 4  # 4 x 4 texels, alpha 255 where i + j is even, 0 elsewhere


def write_checker(tmp_path):
    from PIL import Image

    i, j = np.meshgrid(np.arange(CHECKER), np.arange(CHECKER))
    texels = np.full((CHECKER, CHECKER, 4), 255, np.uint8)
    texels[..., 3] = np.where((i + j) % 2 == 0, 255, 0)
    Image.fromarray(texels, "RGBA").save(tmp_path / "checker.png")


def copies_scene(tmp_path, copies: int, material: dict | None = None) -> Scene:
    """`copies` objects naming one smooth .obj (an icosphere of 1280 faces), on a grid, turned and scaled."""
    trimesh.creation.icosphere(subdivisions=3).export(tmp_path / "ball.obj")
    rng = np.random.default_rng(11)
    objects = [
        {
            "type": "mesh",
            "file": "ball.obj",
            "smooth": True,
            "translate": [1.2 * (i % 6) - 3, 1.2 * (i // 6) - 2.4, 0],
            "rotate": [0, float(rng.uniform(0, 360)), 0],
            "scale": [0.5, float(rng.uniform(0.3, 0.6)), 0.4],
            "material": "m",
        }
        for i in range(copies)
    ]
    data = {
        "cameras": [{"position": [0, 0, 9], "look_at": [0, 0, 0], "fov": 50}],
        "lights": [{"type": "point", "position": [2, 3, 8]}],
        "materials": {"m": material or {"diffuse": [0.8, 0.7, 0.6]}},
        "objects": objects,
    }
    return Scene.from_dict(data, base_dir=tmp_path)
