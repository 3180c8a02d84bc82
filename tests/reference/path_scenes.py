"""The path tracer's reference scenes as clrender scene dicts (issue 25's format), generated with numpy.

Imports nothing from clrender.  Used by tests/trace/test_mitsuba_reference.py (against Mitsuba, through
tests/reference/mitsuba_scenes.py) and by `python -m bench path`.  Every scene is 64 x 64 by default and
lit only by emissive geometry and the constant environment, whose units both renderers share (radiance).

- cornell_box: a diffuse box (red and green side walls) holding a diffuse block, a rough gold-coloured
  metal sphere (glTF metallic 1, roughness 0.3) and a smooth glass sphere (IOR 1.5), lit by an emissive
  square just below the ceiling;
- mesh_light: an emissive icosphere (a triangle mesh) over a diffuse floor, with a diffuse sphere casting
  a shadow;
- environment_spheres: a constant environment over a diffuse floor, a diffuse sphere, two rough metal
  spheres (roughness 0.2 and 0.6) and a glTF dielectric (metallic 0: Lambert under a Schlick coat).
"""

from __future__ import annotations

import numpy as np

WHITE, RED, GREEN = [0.75, 0.75, 0.75], [0.63, 0.065, 0.05], [0.14, 0.45, 0.09]


def quad(corner, edge_a, edge_b, material: str) -> dict:
    """A parallelogram object; its emitting (front) side is edge_a x edge_b."""
    return {"type": "quad", "corner": list(corner), "edge_a": list(edge_a), "edge_b": list(edge_b), "material": material}


def mesh(vertices, faces, material: str) -> dict:
    return {"type": "mesh", "vertices": np.asarray(vertices, float).tolist(), "faces": np.asarray(faces, int).tolist(), "material": material}


def box_mesh(center, size, yaw_degrees: float = 0.0):
    """(vertices, faces) of a box with outward faces (counter-clockwise seen from outside), turned about +y."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]) * np.asarray(size, float)
    t = np.radians(yaw_degrees)
    turn = np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])
    vertices = corners @ turn.T + np.asarray(center, float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]  # -x +x -y +y -z +z
    faces = [f for a, b, c, d in quads for f in ((a, b, c), (a, c, d))]
    return vertices, np.array(faces)


def icosphere(center, radius: float, subdivisions: int = 1):
    """(vertices, faces) of a subdivided icosahedron, faces wound outwards."""
    p = (1 + 5**0.5) / 2
    v = [[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p]]
    v += [[0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8]]
    f += [[3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    vertices = [np.array(x, float) / np.linalg.norm(x) for x in v]
    faces = f
    for _ in range(subdivisions):
        midpoints, new_faces = {}, []
        for a, b, c in faces:
            ab, bc, ca = (_midpoint(vertices, midpoints, i, j) for i, j in ((a, b), (b, c), (c, a)))
            new_faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        faces = new_faces
    vertices, faces = np.array(vertices), np.array(faces)
    normals = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    inward = np.einsum("ij,ij->i", normals, vertices[faces].mean(1)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return vertices * radius + np.asarray(center, float), faces


def _midpoint(vertices: list, midpoints: dict, i: int, j: int) -> int:
    """The index of the unit vector halfway between vertices i and j, added once per edge."""
    key = (min(i, j), max(i, j))
    if key not in midpoints:
        m = vertices[i] + vertices[j]
        vertices.append(m / np.linalg.norm(m))
        midpoints[key] = len(vertices) - 1
    return midpoints[key]


def camera(position, look_at, fov: float) -> dict:
    return {"position": list(position), "look_at": list(look_at), "up": [0, 1, 0], "fov": fov}


def scene(size: int, view: dict, materials: dict, objects: list, environment=None) -> dict:
    """A square scene dict of `size` pixels seen from camera `view`, lit by `environment` (a colour) if given."""
    out = {"width": size, "height": size, "cameras": [view], "materials": materials, "objects": objects}
    if environment is not None:
        out["environment"] = {"color": list(environment)}
    return out


def closed_box(vertices, faces, rho: float = 0.5, le: float = 1.0, size: int = 16) -> dict:
    """The camera inside a closed mesh (vertices, faces wound inwards) whose walls all have albedo rho and emit
    Le inwards: every pixel sees Le (1 - rho^(d + 2)) / (1 - rho) after d bounces (the path tests)."""
    walls = {"wall": {"diffuse": [rho] * 3, "emission": [le] * 3}}
    return scene(size, camera([0.2, 0.1, 0.3], [0, 0, -1], 100), walls, [{"type": "mesh", "vertices": vertices, "faces": faces, "material": "wall"}])


def mixed(size: int = 32) -> dict:
    """An emissive sphere and two diffuse spheres on a floor, under a dim sky."""
    return scene(
        size,
        camera([0, 1.2, 4], [0, 0.5, 0], 45),
        {
            "floor": {"diffuse": [0.7, 0.7, 0.7]},
            "red": {"diffuse": [0.8, 0.2, 0.15]},
            "blue": {"diffuse": [0.15, 0.25, 0.8]},
            "lamp": {"diffuse": [0, 0, 0], "emission": [3, 2.5, 2]},
        },
        [
            quad([-3, 0, -3], [0, 0, 6], [6, 0, 0], "floor"),
            {"type": "sphere", "center": [-0.6, 0.5, 0], "radius": 0.5, "material": "red"},
            {"type": "sphere", "center": [0.6, 0.4, 0.3], "radius": 0.4, "material": "blue"},
            {"type": "sphere", "center": [0.1, 1.5, -0.6], "radius": 0.4, "material": "lamp"},
        ],
        environment=(0.1, 0.12, 0.15),
    )


def cornell_box(size: int = 64, albedo: float = 0.75, radiance: float = 8.0) -> dict:
    """The Cornell box above; `albedo` (the white walls' and block's) and `radiance` (the lamp's) are the
    knobs the z-test's power check turns."""
    white = [albedo] * 3
    objects = [
        quad([-1, 0, -1], [0, 0, 2], [2, 0, 0], "white"),  # floor, facing +y
        quad([-1, 2, -1], [2, 0, 0], [0, 0, 2], "white"),  # ceiling, facing -y
        quad([-1, 0, -1], [2, 0, 0], [0, 2, 0], "white"),  # back wall, facing +z
        quad([-1, 0, -1], [0, 2, 0], [0, 0, 2], "red"),  # left wall, facing +x
        quad([1, 0, -1], [0, 0, 2], [0, 2, 0], "green"),  # right wall, facing -x
        quad([-0.35, 1.98, -0.35], [0.7, 0, 0], [0, 0, 0.7], "lamp"),  # the light, facing down
        mesh(*box_mesh([-0.35, 0.6, -0.4], [0.5, 1.2, 0.5], yaw_degrees=20), "white"),
        {"type": "sphere", "center": [-0.42, 0.35, 0.35], "radius": 0.35, "material": "metal"},
        {"type": "sphere", "center": [0.45, 0.35, 0.2], "radius": 0.35, "material": "glass"},
    ]
    return {
        "width": size,
        "height": size,
        "cameras": [camera([0, 1, 4.3], [0, 1, 0], 36)],
        "materials": {
            "white": {"diffuse": white},
            "red": {"diffuse": RED},
            "green": {"diffuse": GREEN},
            "lamp": {"diffuse": [0, 0, 0], "emission": [radiance] * 3},
            "metal": {"base_color": [0.9, 0.65, 0.3], "metallic": 1.0, "roughness": 0.3},
            "glass": {"transmission": 1.0, "ior": 1.5, "roughness": 0.0},
        },
        "objects": objects,
    }


def mesh_light(size: int = 64, radiance: float = 6.0) -> dict:
    """An emissive icosphere (80 triangles) over a diffuse floor and a diffuse sphere."""
    return {
        "width": size,
        "height": size,
        "cameras": [camera([0, 2.2, 3.0], [0, 0.3, 0], 45)],
        "materials": {
            "floor": {"diffuse": [0.7, 0.7, 0.65]},
            "ball": {"diffuse": [0.25, 0.45, 0.75]},
            "lamp": {"diffuse": [0, 0, 0], "emission": [radiance, radiance * 0.85, radiance * 0.6]},
        },
        "objects": [
            quad([-2, 0, -2], [0, 0, 4], [4, 0, 0], "floor"),
            mesh(*icosphere([-0.3, 1.1, -0.2], 0.3), "lamp"),
            {"type": "sphere", "center": [0.45, 0.35, 0.2], "radius": 0.35, "material": "ball"},
        ],
    }


def environment_spheres(size: int = 64) -> dict:
    """A constant sky over a diffuse floor, a diffuse sphere, two rough metals and a glTF dielectric."""
    return {
        "width": size,
        "height": size,
        "cameras": [camera([0, 1.4, 3.6], [0, 0.4, 0], 40)],
        "environment": {"color": [0.8, 0.9, 1.0]},
        "materials": {
            "floor": {"diffuse": [0.5, 0.5, 0.5]},
            "clay": {"diffuse": [0.7, 0.3, 0.2]},
            "gold": {"base_color": [0.95, 0.75, 0.35], "metallic": 1.0, "roughness": 0.2},
            "steel": {"base_color": [0.6, 0.6, 0.65], "metallic": 1.0, "roughness": 0.6},
            "plastic": {"base_color": [0.2, 0.5, 0.3], "metallic": 0.0, "roughness": 0.4},
        },
        "objects": [
            quad([-4, 0, -4], [0, 0, 8], [8, 0, 0], "floor"),
            {"type": "sphere", "center": [-1.1, 0.45, 0], "radius": 0.45, "material": "clay"},
            {"type": "sphere", "center": [-0.05, 0.45, -0.3], "radius": 0.45, "material": "gold"},
            {"type": "sphere", "center": [1.0, 0.45, 0], "radius": 0.45, "material": "steel"},
            {"type": "sphere", "center": [0.3, 0.25, 0.8], "radius": 0.25, "material": "plastic"},
        ],
    }


SCENES = {"cornell_box": cornell_box, "mesh_light": mesh_light, "environment_spheres": environment_spheres}
