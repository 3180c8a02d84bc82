"""Ray packets (kernels/packet.h): eight consecutive rays that share a direction octant (sign bits, -0
negative) and a dominant axis walk the 8- or 4-wide BVH together.  Packets may change the speed and
nothing else: with Tracer(ray_packets=True) and ray_packets=False every ray gets the same t (float32
bits), the same primitive (of equal t, the lowest id), the same object and the same occluded flag.

Checked in coherent camera views, along the axes with +0 and -0 components, at shared edges and
vertices, grazing a face, with a t_min per ray, with hits and misses in one packet, among spheres,
for any ray count, in any order and with an overflowing stack; and the answers are the right ones:
a float64 brute force, the every-primitive walk (use_bvh=False) and Embree agree with them.
"""

import inspect

import numpy as np
import pytest
import trimesh

from clrender.scene.camera import Camera
from clrender.scene.meshes import dense_mesh
from clrender.scene.scene import Scene
from clrender.trace.knobs import TraceKnobs
from clrender.trace.tracer import Tracer

from tests.meshtools import grid_mesh, triangles_containing

PACKET = 8  # rays 8k .. 8k + 7 form one packet
WIDTHS = [8, 4]  # the BVH widths that walk packets (width 2 and use_bvh=False never do)


# ------------------------------------------------------------------ helpers
def dominant_axis(d):
    """The largest |d| component, ties as kernels/common.h shear_ray breaks them (toward the later axis)."""
    a = np.abs(d)
    return np.where(a[:, 0] > a[:, 1], np.where(a[:, 0] > a[:, 2], 0, 2), np.where(a[:, 1] > a[:, 2], 1, 2))


def packet_share(directions):
    """Fraction of the whole groups of 8 consecutive rays that can walk as one packet: one octant and
    one dominant axis.  A check on a test's rays (that it exercises packets), not on the tracer."""
    d = np.asarray(directions, np.float32).reshape(-1, 3)
    whole = len(d) // PACKET * PACKET
    if whole == 0:
        return 0.0
    key = np.signbit(d[:whole]) @ np.array([1, 2, 4]) + 8 * dominant_axis(d[:whole])
    key = key.reshape(-1, PACKET)
    return float((key == key[:, :1]).all(1).mean())


def assert_same_hits(a, b, what):
    """Bit for bit: t's float32 bits, primitive ids and object ids."""
    (t_a, prim_a, obj_a), (t_b, prim_b, obj_b) = a, b
    np.testing.assert_array_equal(np.asarray(t_a, np.float32).view(np.uint32), np.asarray(t_b, np.float32).view(np.uint32), err_msg=f"{what}: t bits")
    np.testing.assert_array_equal(prim_a, prim_b, err_msg=f"{what}: primitive")
    np.testing.assert_array_equal(obj_a, obj_b, err_msg=f"{what}: object")


def packets_change_nothing(scene, o, d, device, *, t_min=0.0, t_max=np.inf, bvh_width=8, **options):
    """Closest hits and occlusion with packets on and off: asserts they are the same bit for bit and
    returns the packets-on answers ((t, prim, obj), occluded)."""
    on, off = (Tracer(scene, ray_packets=packets, bvh_width=bvh_width, device=device, **options) for packets in (True, False))
    hits = on.intersect(o, d, t_min)
    assert_same_hits(hits, off.intersect(o, d, t_min), f"width {bvh_width}, packets on vs off")
    blocked = on.occluded(o, d, t_max, t_min)
    np.testing.assert_array_equal(blocked, off.occluded(o, d, t_max, t_min), err_msg=f"width {bvh_width}, packets on vs off: occluded")
    return hits, blocked


def camera_rays(eye, look_at, width, height, fov=40.0):
    """Unit pinhole rays through the pixel centres, in 4 x 2 pixel tiles: each group of 8 consecutive
    rays is a tile of neighbouring pixels, as a renderer would hand them over."""
    o, d = Camera(position=tuple(eye), look_at=tuple(look_at), fov=fov).rays(width, height)

    def tiles(a):
        return a.reshape(height // 2, 2, width // 4, 4, 3).transpose(0, 2, 1, 3, 4).reshape(-1, 3)

    return tiles(o), tiles(d)


def merged(*meshes):
    """One (vertices, faces) mesh of several, ids in the order given."""
    vertices, faces, base = [], [], 0
    for v, f in meshes:
        vertices.append(np.asarray(v, float))
        faces.append(np.asarray(f) + base)
        base += len(v)
    return np.concatenate(vertices), np.concatenate(faces)


def lumpy_mesh(n_triangles=8000, seed=1):
    mesh = dense_mesh(n_triangles, seed=seed)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def icosphere():
    mesh = trimesh.creation.icosphere(subdivisions=4)  # 5120 triangles, radius 1
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


MESHES = {"lumpy": lumpy_mesh, "icosphere": icosphere}


def brute_force_hits(vertices, faces, o, d, margin=1e-5):
    """float64 Moller-Trumbore of every ray against every triangle.  Returns the nearest t (inf on a
    miss), its primitive (-1) and `clear`: the ray is no near call, i.e. no triangle it grazes within
    `margin` (barycentric) is nearer, its hit lies `margin` inside the triangle and the next hit is
    more than `margin` (relative) farther."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    n = len(o)
    t_best, prim, clear = np.full(n, np.inf), np.full(n, -1), np.zeros(n, bool)
    for lo in range(0, n, 128):
        oc, dc = o[lo : lo + 128, None, :], d[lo : lo + 128, None, :]
        p = np.cross(dc, e2)
        det = (e1 * p).sum(-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = oc - v0
            u = (s * p).sum(-1) * inv
            q = np.cross(s, e1)
            v = (dc * q).sum(-1) * inv
            t = (e2 * q).sum(-1) * inv
        inside = np.minimum(np.minimum(u, v), 1 - u - v)  # smallest barycentric
        near = (det != 0) & (inside >= -margin) & (t > 0)
        t_near = np.where(near, t, np.inf)
        k = np.argmin(t_near, 1)
        rows = np.arange(len(k))
        first = t_near[rows, k]
        second = np.partition(t_near, 1, axis=1)[:, 1] if t_near.shape[1] > 1 else np.full(len(k), np.inf)
        hit = np.isfinite(first)
        t_best[lo : lo + 128] = first
        prim[lo : lo + 128] = np.where(hit, k, -1)
        clear[lo : lo + 128] = ~hit | ((inside[rows, k] > margin) & (second > first * (1 + margin)))
    return t_best, prim, clear


# ------------------------------------------------------------------ 1. coherent rays: packets on == off
def test_packets_are_on_by_default():
    assert inspect.signature(Tracer).parameters["ray_packets"].default is True


@pytest.mark.parametrize("builder", ["sah", "median"])
@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("mesh", sorted(MESHES))
def test_camera_view_is_bit_identical_with_packets_on_and_off(device, mesh, width, builder):
    o, d = camera_rays([0.3, 0.4, 3.0], [0, 0, 0], 64, 48)
    assert packet_share(d) > 0.85  # all but the tiles that straddle the centre row or column
    (t, prim, obj), blocked = packets_change_nothing(MESHES[mesh](), o, d, device, t_max=2.2, bvh_width=width, builder=builder)
    hit = np.isfinite(t)
    assert 0.3 < hit.mean() < 0.9  # the silhouette crosses packets: some lanes hit, some miss
    assert (prim[hit] >= 0).all() and (obj[hit] == 0).all() and (prim[~hit] == -1).all()
    # any-hit and closest-hit are two walks: occluded within 2.2 exactly where the nearest hit is nearer
    np.testing.assert_array_equal(blocked, t < 2.2)
    assert 0.05 < blocked.mean() < hit.mean()


@pytest.mark.parametrize("width", WIDTHS)
def test_coherent_rays_do_walk_as_packets(device, width):
    """The comparisons above would pass just as well if no packet ever ran.  The one outward sign of a
    packet walk is its visit counts: a packet carries each ray through the nodes that ray's box test
    passes, in the packet's order, so a ray's count may differ from its walk alone; rays in groups
    that cannot be packets take the single-ray walks and count exactly as they do with packets off."""
    mesh = lumpy_mesh(8000, seed=1)
    o, d = camera_rays([0.3, 0.4, 3.0], [0, 0, 0], 64, 48)
    d32 = d.astype(np.float32)
    key = (np.signbit(d32) @ np.array([1, 2, 4]) + 8 * dominant_axis(d32)).reshape(-1, PACKET)
    in_packet = np.repeat((key == key[:, :1]).all(1), PACKET)
    visits = {}
    for packets in (True, False):
        tracer = Tracer(mesh, ray_packets=packets, bvh_width=width, device=device)
        tracer.intersect(o, d)
        visits[packets] = tracer.last_visits.copy()
    np.testing.assert_array_equal(visits[True][~in_packet], visits[False][~in_packet])
    assert (visits[True][in_packet] != visits[False][in_packet]).any()


def boxes_grid():
    """27 unit cubes centred at (2i, 2j, 2k), i, j, k in -1, 0, 1."""
    box = trimesh.creation.box(extents=(1, 1, 1))
    centres = np.array(np.meshgrid(*[[-2.0, 0.0, 2.0]] * 3, indexing="ij")).reshape(3, -1).T
    return merged(*[(box.vertices + c, box.faces) for c in centres])


def axis_rays():
    """Rays along +-x, +-y, +-z from 6 units out, their other two components exactly 0: +0 or -0 in
    each of the four combinations (whole packets of one kind) and, fifth, alternating +0 and -0 from
    ray to ray (packets that must fall back).  Sideways positions on a 0.25 lattice (edges included)."""
    lattice = np.arange(-3.5, 3.75, 0.25)
    sideways = np.array(np.meshgrid(lattice, lattice, indexing="ij")).reshape(2, -1).T
    n = len(sideways)
    origins, directions = [], []
    for axis in range(3):
        others = [a for a in range(3) if a != axis]
        for sign in (1.0, -1.0):
            for zeros in ((0.0, 0.0), (0.0, -0.0), (-0.0, 0.0), (-0.0, -0.0), "alternating"):
                d = np.zeros((n, 3))
                d[:, axis] = sign
                if zeros == "alternating":
                    d[1::2, others[0]] = -0.0
                    d[2::4, others[1]] = -0.0
                else:
                    d[:, others] = zeros
                o = np.zeros((n, 3))
                o[:, axis] = -6.0 * sign
                o[:, others] = sideways
                origins.append(o)
                directions.append(d)
    return np.concatenate(origins), np.concatenate(directions)


@pytest.mark.parametrize("width", WIDTHS)
def test_axis_parallel_rays_with_signed_zeros_onto_a_grid_of_cubes(device, width):
    o, d = axis_rays()
    assert np.signbit(d[d == 0]).mean() == pytest.approx(0.5, abs=0.05)  # as many -0 as +0
    assert 0.75 < packet_share(d) < 0.85  # four kinds of five walk as packets
    vertices, faces = boxes_grid()
    hits, blocked = packets_change_nothing((vertices, faces), o, d, device, bvh_width=width)
    t = hits[0]
    # analytic: a ray whose sideways position lies inside a column of cubes enters the first one at
    # 6 - 2.5 = 3.5; one that passes beside every column misses; those along an edge are left to the
    # comparison with the every-primitive walk
    off_centre = np.abs(o - 2 * np.clip(np.round(o / 2), -1, 1))
    side = off_centre.max(1, where=d == 0, initial=0)
    inside, beside = side < 0.5, side > 0.5
    assert inside.sum() > 2000 and beside.sum() > 2000
    np.testing.assert_array_equal(t[inside], 3.5)
    np.testing.assert_array_equal(t[beside], np.inf)
    hits_ref = Tracer((vertices, faces), use_bvh=False, device=device).intersect(o, d)
    assert_same_hits(hits, hits_ref, "packets vs every primitive")
    np.testing.assert_array_equal(blocked, np.isfinite(t))


@pytest.mark.parametrize("width", WIDTHS)
def test_dominant_axis_ties_are_broken_as_the_single_ray_test_breaks_them(device, rng, width):
    """Directions with two or three equally large components: the packet's shared permutation must be
    the one shear_ray gives each ray alone (a tie goes to the later axis), or t would round differently.
    The last kind mixes a tie (y dominant) with rays a hair off it (x dominant): no packet."""
    mesh = lumpy_mesh(4000, seed=10)
    ties = [[1.0, 1.0, 0.3], [-1.0, 1.0, 0.3], [1.0, 0.3, -1.0], [0.3, -1.0, -1.0], [1.0, 1.0, 1.0], [-1.0, -1.0, -1.0]]
    origins, directions = [], []
    for tie in ties + ["mixed"] * 4:
        d = np.tile([1.0, 1.0, 0.3] if tie == "mixed" else tie, (PACKET * 8, 1))
        if tie == "mixed":
            d[1::2, 1] = np.float32(1.0) - np.float32(2**-23)  # two float32 steps below 1
        side = rng.uniform(-0.7, 0.7, (len(d), 3))
        side -= (side * d).sum(1, keepdims=True) / (d * d).sum(1, keepdims=True) * d  # across the ray
        origins.append(side - 2.5 * d)
        directions.append(d)
    o, d = np.concatenate(origins), np.concatenate(directions)
    axes = dominant_axis(d.astype(np.float32))
    # x == y > z goes to y, x == z > y and y == z > x and x == y == z to z; mixed: y, x, y, x, ...
    expected = np.concatenate([np.repeat([1, 1, 2, 2, 2, 2], PACKET * 8), np.tile([1, 0], 4 * PACKET * 4)])
    np.testing.assert_array_equal(axes, expected)
    assert packet_share(d) == pytest.approx(0.6)  # the six tie kinds do, the mixed ones don't
    (t, _, _), _ = packets_change_nothing(mesh, o, d, device, bvh_width=width)
    assert np.isfinite(t).mean() > 0.5


def lattice_points(n_cells):
    """Every vertex and edge midpoint of the interior of an n x n unit grid (exact in float32), ordered
    row by row so that 8 consecutive points are neighbours."""
    return np.array([[x / 2, y / 2] for y in range(2, 2 * n_cells - 1) for x in range(2, 2 * n_cells - 1)])


@pytest.mark.parametrize("width", WIDTHS)
def test_rays_at_shared_edges_and_vertices_go_to_the_lowest_id(device, width):
    vertices, faces = grid_mesh(8)
    pts = lattice_points(8)  # 169 points: not a whole number of packets either
    o = np.c_[pts, np.full(len(pts), 5.0)]
    down = np.tile([0.0, 0.0, -1.0], (len(pts), 1))
    # reference: the lowest id among the triangles whose closed area contains the point
    contains = triangles_containing(vertices, faces, pts)
    assert contains.sum(0).max() == 6 and contains.sum(0).min() == 2  # vertices on six triangles, edges on two
    assert packet_share(down) == 1.0
    (t, prim, _), _ = packets_change_nothing((vertices, faces), o, down, device, bvh_width=width)
    np.testing.assert_array_equal(t, 5.0)
    np.testing.assert_array_equal(prim, np.argmax(contains, axis=0))
    # tilted rays through the same points (origins exact in float32: the rays pass exactly through them)
    tilted = np.tile([0.25, -0.125, -1.0], (len(pts), 1))
    hits, _ = packets_change_nothing((vertices, faces), np.c_[pts, np.zeros(len(pts))] - 4 * tilted, tilted, device, bvh_width=width)
    assert (hits[1] >= 0).all()  # no ray slips through a vertex or an edge
    hits_ref = Tracer((vertices, faces), use_bvh=False, device=device).intersect(np.c_[pts, np.zeros(len(pts))] - 4 * tilted, tilted)
    assert_same_hits(hits, hits_ref, "tilted: packets vs every primitive")


GRAZING_SLOPES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def grazing_rays(rng):
    """Rays crossing the grid's plane z = 0 at grazing slopes 1e-2 .. 1e-6 (a packet per slope and row),
    rays parallel to it just above (miss), and rays inside the plane itself (+0 and -0 as z)."""
    origins, directions = [], []
    for slope in GRAZING_SLOPES:
        for row in range(8):
            reach = rng.uniform(0.5, 7.5, PACKET)  # where along x the ray meets the plane
            d = np.c_[np.ones(PACKET), (-1) ** row * rng.uniform(0.001, 0.05, PACKET), np.full(PACKET, -slope)]
            o = np.c_[np.full(PACKET, -1.0), row + 0.5 + rng.uniform(-0.3, 0.3, PACKET), slope * (reach + 1.0)]
            origins.append(o)
            directions.append(d)
    for z, dz in ((1e-6, 0.0), (1e-6, -0.0), (0.0, 0.0), (0.0, -0.0)):
        for row in range(4):
            origins.append(np.c_[np.full(PACKET, -1.0), 2 * row + 0.5 + rng.uniform(-0.3, 0.3, PACKET), np.full(PACKET, z)])
            directions.append(np.c_[np.ones(PACKET), (-1) ** row * rng.uniform(0.001, 0.05, PACKET), np.full(PACKET, dz)])
    return np.concatenate(origins), np.concatenate(directions)


@pytest.mark.parametrize("width", WIDTHS)
def test_grazing_rays_nearly_in_a_faces_plane(device, rng, width):
    vertices, faces = grid_mesh(8)
    o, d = grazing_rays(rng)
    assert packet_share(d) > 0.9
    hits, _ = packets_change_nothing((vertices, faces), o, d, device, bvh_width=width)
    t = hits[0]
    o32, d32 = o.astype(np.float32).astype(float), d.astype(np.float32).astype(float)
    # float64 reference on the float32 rays: the plane is met at t = z / -dz, inside the grid.  Below a
    # slope of 1e-4 the triangle test's own error bound (pbrt's deltaT) grows past t and may reject
    # the hit: those rays are left to the comparisons
    crossing = d[:, 2] <= -1e-4
    assert crossing.sum() == 3 * 8 * PACKET
    t_plane = o32[crossing, 2] / -d32[crossing, 2]
    np.testing.assert_allclose(t[crossing], t_plane, rtol=1e-5)
    above = (d[:, 2] == 0) & (o[:, 2] > 0)
    np.testing.assert_array_equal(t[above], np.inf)  # parallel just above: never meets it
    hits_ref = Tracer((vertices, faces), use_bvh=False, device=device).intersect(o, d)
    assert_same_hits(hits, hits_ref, "packets vs every primitive")


@pytest.mark.parametrize("width", WIDTHS)
def test_a_t_min_per_ray_skips_nearer_layers_inside_one_packet(device, rng, width):
    """Four grids at z = -1 .. -4, rays down from z = 0; in every packet each ray has its own t_min."""
    layers = merged(*[grid_mesh(6, z=-k) for k in (1, 2, 3, 4)])
    n = 8 * 40
    o = np.c_[rng.uniform(0.1, 5.9, (n, 2)), np.zeros(n)]
    down = np.tile([0.0, 0.0, -1.0], (n, 1))
    t_min = np.tile([0.0, 0.5, 1.01, 1.5, 2.5, 3.01, 3.5, 10.0], n // 8)  # t <= t_min is skipped
    (t, prim, _), blocked = packets_change_nothing(layers, o, down, device, t_min=t_min, t_max=3.8, bvh_width=width)
    layer = np.where(prim >= 0, prim // 72 + 1, -1)  # 72 triangles a layer, ids layer by layer
    np.testing.assert_array_equal(layer, np.tile([1, 1, 2, 2, 3, 4, 4, -1], n // 8))
    np.testing.assert_allclose(t, np.tile([1, 1, 2, 2, 3, 4, 4, np.inf], n // 8), rtol=1e-6)  # to float32 rounding
    np.testing.assert_array_equal(blocked, np.tile([1, 1, 1, 1, 1, 0, 0, 0], n // 8).astype(bool))
    # the same with tilted rays (t along the direction as given, not unit length)
    tilted = np.tile([0.01, 0.02, -2.0], (n, 1))
    (t, _, _), _ = packets_change_nothing(layers, o, tilted, device, t_min=t_min / 2, bvh_width=width)
    np.testing.assert_allclose(t, np.tile([0.5, 0.5, 1, 1, 1.5, 2, 2, np.inf], n // 8), rtol=1e-6)


def mixed_packets(rng, n_packets):
    """Packets of 8 parallel rays at the unit sphere, each packet in a random direction (every octant
    and dominant axis turns up); packet j has j % 9 rays aimed within 0.6 of the centre line (hits)
    and the rest 1.2 or more beside it (misses), in random lanes."""
    origins, directions, aimed = [], [], []
    for j in range(n_packets):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        u = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
        u /= np.linalg.norm(u)
        v = np.cross(d, u)
        hits = rng.permutation(np.arange(PACKET) < j % 9)
        radius = np.where(hits, rng.uniform(0, 0.6, PACKET), rng.uniform(1.2, 2.0, PACKET))
        angle = rng.uniform(0, 2 * np.pi, PACKET)
        beside = radius[:, None] * (np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * v)
        origins.append(beside - 5 * d)
        directions.append(np.tile(d, (PACKET, 1)))
        aimed.append(hits)
    return np.concatenate(origins), np.concatenate(directions), np.concatenate(aimed)


@pytest.mark.parametrize("width", WIDTHS)
def test_packets_where_some_rays_hit_and_others_miss(device, rng, width):
    sphere = trimesh.creation.icosphere(subdivisions=3)  # its faces lie 0.99 .. 1 from the centre
    o, d, aimed = mixed_packets(rng, 90)
    assert packet_share(d) == 1.0 and len(set(dominant_axis(d))) == 3 and len({tuple(s) for s in np.signbit(d)}) == 8
    (t, _, _), blocked = packets_change_nothing(sphere, o, d, device, bvh_width=width)
    np.testing.assert_array_equal(np.isfinite(t), aimed)
    np.testing.assert_array_equal(blocked, aimed)
    assert np.all((t[aimed] > 3.99) & (t[aimed] < 4.22))  # the near side: 5 - sqrt(r^2 - 0.6^2) at most, r = 0.99 .. 1


def spheres_and_mesh_scene():
    """A lumpy mesh (600 triangles, object 0) among 40 random spheres (objects 1..40), some inside or
    overlapping it, as in tests/trace/test_leaf_blocks.py: leaves that mix spheres and triangles."""
    rng = np.random.default_rng(5)
    objects = [{"type": "mesh", "generator": "dense", "params": {"n_triangles": 600, "seed": 5}}]
    for c, r in zip(rng.uniform(-1.5, 1.5, (40, 3)), rng.uniform(0.05, 0.4, 40)):
        objects.append({"type": "sphere", "center": c.tolist(), "radius": float(r)})
    return Scene.from_dict({"objects": objects})


@pytest.mark.parametrize("width", WIDTHS)
def test_spheres_among_triangles(device, width):
    scene = spheres_and_mesh_scene()
    o, d = camera_rays([0.2, 0.5, 5.0], [0, 0, 0], 48, 48, fov=50)
    (t, prim, obj), blocked = packets_change_nothing(scene, o, d, device, t_max=4.5, bvh_width=width)
    assert (prim >= 600).sum() > 100 and (prim[np.isfinite(t)] < 600).sum() > 100  # spheres and triangles in view
    assert len(np.unique(obj[prim >= 600])) > 10 and (obj[(prim >= 0) & (prim < 600)] == 0).all()
    np.testing.assert_array_equal(blocked, t < 4.5)


@pytest.mark.parametrize("width", WIDTHS)
def test_rays_from_inside_a_sphere_leave_it_at_the_radius(device, width):
    """Packets of rays from a sphere's centre: each ray's hit is the far root, t = radius (the near
    root is behind the origin), with packets as without; a shadow ray shorter than the radius is not
    blocked, a longer one is."""
    scene = Scene.from_dict({"objects": [{"type": "sphere", "center": [0.5, -0.25, 2.0], "radius": 1.5}]})
    rng = np.random.default_rng(7)
    d = np.abs(rng.normal(size=(64, 3))) + 0.05  # one octant, so groups of eight form packets
    o = np.tile([0.5, -0.25, 2.0], (64, 1))
    (t, prim, _), blocked = packets_change_nothing(scene, o, d, device, t_max=1.4 / np.linalg.norm(d, axis=1), bvh_width=width)
    np.testing.assert_allclose(t * np.linalg.norm(d, axis=1), 1.5, rtol=1e-5)
    assert (prim == 0).all() and not blocked.any()
    far = packets_change_nothing(scene, o, d, device, t_max=1.6 / np.linalg.norm(d, axis=1), bvh_width=width)[1]
    assert far.all()


@pytest.mark.parametrize("start, count", [(0, 1), (0, 7), (0, 9), (0, 17), (0, 1003), (5, 1003)])
def test_any_ray_count_gives_each_ray_its_answer_in_the_whole_batch(device, start, count):
    """A ray's answer does not depend on how many rays come with it or where the packets are cut (an
    incomplete last group of 8 is filled with copies of the last ray)."""
    mesh = lumpy_mesh(2000, seed=2)
    o, d = camera_rays([0.3, 0.4, 4.0], [0, 0, 0], 32, 32)
    whole = Tracer(mesh, device=device).intersect(o, d)
    part = slice(start, start + count)
    hits, blocked = packets_change_nothing(mesh, o[part], d[part], device)
    assert_same_hits(hits, tuple(a[part] for a in whole), f"rays {start}..{start + count - 1} vs all {len(o)}")
    np.testing.assert_array_equal(blocked, np.isfinite(whole[0][part]))


# ------------------------------------------------------------------ 2. the right answers
def test_packet_hits_match_a_float64_brute_force(device):
    vertices, faces = lumpy_mesh(3000, seed=4)
    o, d = camera_rays([-0.5, 1.0, 3.5], [0, 0, 0], 48, 32)
    (t, prim, obj), _ = packets_change_nothing((vertices, faces), o, d, device)
    # the reference sees the rays the kernels see: float32 origins and directions
    t_ref, prim_ref, clear = brute_force_hits(vertices, faces, o.astype(np.float32).astype(float), d.astype(np.float32).astype(float))
    assert clear.mean() > 0.97 and 0.3 < np.isfinite(t_ref).mean() < 0.9
    np.testing.assert_array_equal(prim[clear], prim_ref[clear])
    hit = clear & np.isfinite(t_ref)
    np.testing.assert_allclose(t[hit], t_ref[hit], rtol=1e-6)  # a few float32 ulps
    assert_same_hits((t, prim, obj), Tracer((vertices, faces), use_bvh=False, device=device).intersect(o, d), "packets vs every primitive")


def test_packet_hits_agree_with_embree(device):
    embree = pytest.importorskip("embreex.rtcore_scene")
    from embreex.mesh_construction import TriangleMesh

    vertices, faces = lumpy_mesh(5000, seed=3)
    o, d = camera_rays([0.5, -0.3, 3.0], [0, 0, 0], 48, 32)
    (t, prim, _), _ = packets_change_nothing((vertices, faces), o, d, device)
    scene = embree.EmbreeScene()
    TriangleMesh(scene, np.asarray(vertices, np.float32)[faces])
    res = scene.run(o.astype(np.float32), d.astype(np.float32), output=1)
    t_embree, prim_embree = res["tfar"], res["primID"]
    # rays that graze the silhouette or land on an edge may go either way: compare the clear ones
    _, _, clear = brute_force_hits(vertices, faces, o.astype(np.float32).astype(float), d.astype(np.float32).astype(float))
    assert clear.mean() > 0.97
    both = clear & np.isfinite(t)
    np.testing.assert_array_equal(np.isfinite(t)[clear], (prim_embree >= 0)[clear])
    np.testing.assert_array_equal(prim[both], prim_embree[both])
    np.testing.assert_allclose(t[both], t_embree[both], rtol=1e-5)


# ------------------------------------------------------------------ 3. order independence
@pytest.mark.parametrize("width", WIDTHS)
def test_permuted_rays_give_the_same_answers(device, width):
    """Shuffled, the rays no longer form packets (they go through the pair walks); un-shuffled, every
    answer is the same bit for bit."""
    mesh = lumpy_mesh(4000, seed=6)
    o, d = camera_rays([0.0, 0.6, 2.8], [0.1, 0, 0], 64, 32)
    rng = np.random.default_rng(17)
    length = rng.uniform(0.5, 2.0, len(o))
    d = d * length[:, None]  # t counts in each ray's own units
    order = rng.permutation(len(o))
    assert packet_share(d) > 0.85 and packet_share(d[order]) < 0.3
    tracer = Tracer(mesh, bvh_width=width, device=device)
    # some rays skip their nearest hit (at 1.8 .. 2.6 from the eye); the segments of the shadow queries end at 2.3
    t_min = np.where(np.arange(len(o)) % 5 == 0, 2.2, 0.0) / length
    t_max = 2.3 / length
    coherent = tracer.intersect(o, d, t_min)
    blocked = tracer.occluded(o, d, t_max, t_min)
    shuffled, blocked_shuffled = packets_change_nothing(mesh, o[order], d[order], device, t_min=t_min[order], t_max=t_max[order], bvh_width=width)
    unshuffle = np.argsort(order)
    assert_same_hits(tuple(a[unshuffle] for a in shuffled), coherent, "shuffled vs coherent")
    np.testing.assert_array_equal(blocked_shuffled[unshuffle], blocked)
    assert np.isfinite(coherent[0]).mean() > 0.3 and 0.05 < blocked.mean() < 0.95


# ------------------------------------------------------------------ 4. shadow rays (any hit)
def lumpy_over_floor():
    """The lumpy sphere floating 1.2 above a floor of 800 triangles (y = 0, 16 x 16), ids: sphere first."""
    sphere_v, sphere_f = lumpy_mesh(4000, seed=7)
    floor_v, floor_f = grid_mesh(20)
    floor_v = np.c_[floor_v[:, 0] * 0.8 - 8, np.zeros(len(floor_v)), floor_v[:, 1] * 0.8 - 8]
    return merged((sphere_v * 0.8 + [0, 1.2, 0], sphere_f), (floor_v, floor_f))


@pytest.mark.parametrize("width", WIDTHS)
def test_shadow_rays_toward_a_point_light(device, width):
    mesh = lumpy_over_floor()
    light = np.array([2.0, 3.0, 1.0])
    o, d = camera_rays([0.0, 3.5, 3.0], [0, 0.8, 0], 48, 32, fov=50)
    t, _, _ = Tracer(mesh, use_bvh=False, device=device).intersect(o, d)
    assert np.isfinite(t).all()  # the floor fills the background
    surface = o + t[:, None] * d  # rows stay in 4 x 2 pixel tiles: neighbouring shadow rays
    to_light = light - surface
    distance = np.linalg.norm(to_light, axis=1)
    to_light /= distance[:, None]
    assert packet_share(to_light) > 0.7
    t_min = 1e-3  # past the surface the ray leaves (its float32 error is far smaller)
    (t_hit, _, _), blocked = packets_change_nothing(mesh, surface, to_light, device, t_min=t_min, t_max=distance, bvh_width=width)
    assert 0.1 < blocked.mean() < 0.9  # the sphere's shadow on the floor, and its own dark side
    np.testing.assert_array_equal(blocked, Tracer(mesh, use_bvh=False, device=device).occluded(surface, to_light, distance, t_min))
    np.testing.assert_array_equal(blocked, t_hit < distance)  # any hit before the light <=> nearest hit before it


# ------------------------------------------------------------------ 5. an overflowing stack
def stacked_triangles():
    """300 copies of one triangle (ids 0..299: ties), 100 copies stacked 0.001 apart below it
    (ids 300..399) and 30 scattered others: nothing for a builder to split on."""
    rng = np.random.default_rng(21)
    base = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    coincident = np.tile(base, (300, 1, 1))
    stacked = base[None] - np.arange(1, 101)[:, None, None] * [0, 0, 1e-3]
    scattered = rng.uniform(-2, 2, (30, 3, 3)) - [0, 0, 3]  # all below the stack
    tri = np.concatenate([coincident, stacked, scattered])
    return tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3)


# width 4 is slow only for its own two kernel builds (a few seconds when PoCL's cache is cold)
WIDTHS_8_FAST = [8, pytest.param(4, marks=pytest.mark.slow)]


@pytest.mark.parametrize("width", WIDTHS_8_FAST)
def test_an_overflowing_stack_still_finds_the_brute_force_answers(device, width):
    """A binary stack of 2: the kernels' traversal stacks overflow on purpose; packets and their fallback
    still answer what the every-primitive walk answers."""
    tiny_stacks = TraceKnobs(stack_size=2)
    mesh = stacked_triangles()
    rng = np.random.default_rng(22)
    n = 8 * 60
    target = np.c_[rng.dirichlet([1, 1, 1], n)[:, :2] * 0.98 + 0.005, np.zeros(n)]  # inside the triangle
    d = np.tile([0.05, 0.03, -1.0], (n, 1)) + np.c_[rng.uniform(-0.01, 0.01, (n, 2)), np.zeros(n)]
    o = target - 5 * d
    t_min = np.where(np.arange(n) % 3 == 2, 5.0005, 0.0)  # every third ray skips the coincident copies
    assert packet_share(d) == 1.0
    hits, blocked = packets_change_nothing(mesh, o, d, device, t_min=t_min, t_max=5.05, bvh_width=width, knobs=tiny_stacks)
    prim = hits[1]
    np.testing.assert_array_equal(prim[t_min == 0], 0)  # of 300 copies at the same t, the lowest id
    assert (prim[t_min > 0] == 300).mean() > 0.9  # the nearest stacked copy below (few rays hit a scattered one first)
    flat = Tracer(mesh, use_bvh=False, device=device)
    assert_same_hits(hits, flat.intersect(o, d, t_min), "overflow: packets vs every primitive")
    np.testing.assert_array_equal(blocked, flat.occluded(o, d, 5.05, t_min))


# ------------------------------------------------------------------ 6. random meshes, random packets
try:
    from hypothesis import assume, given, settings
    from hypothesis import strategies as st
    from hypothesis.extra.numpy import arrays
except ImportError:  # hypothesis is in the `test` extra
    given = None

if given is not None:
    lattice = st.integers(-4, 4).map(lambda k: k / 4)  # coarse coordinates: shared edges, coincident and flat triangles

    @st.composite
    def meshes_and_packets(draw):
        """A small random mesh and a few packets from one origin in a narrow cone (plus a few odd rays)."""
        tri = draw(arrays(np.float64, (draw(st.integers(1, 24)), 3, 3), elements=lattice))
        if draw(st.booleans()):
            tri = np.concatenate([tri, tri[: draw(st.integers(1, len(tri)))]])  # some triangles twice
        origin = draw(arrays(np.float64, 3, elements=st.floats(-3, 3, width=32)))
        target = draw(arrays(np.float64, 3, elements=lattice))  # through a lattice point: vertices, edges
        axis = target - origin
        assume(np.linalg.norm(axis) > 0.1)  # not from the lattice point itself
        n_rays = PACKET * draw(st.integers(1, 4)) + draw(st.integers(0, 7))
        spread = draw(st.sampled_from([0.0, 1e-4, 1e-2, 0.1, 0.25]))  # 0: eight identical rays
        jitter = draw(arrays(np.float64, (n_rays, 3), elements=st.floats(-1, 1)))
        d = axis + spread * np.linalg.norm(axis) * jitter  # never zero: |spread * jitter| < 0.5
        t_min = draw(arrays(np.float64, n_rays, elements=st.sampled_from([0.0, 0.0, 0.5, 1.0])))
        return tri, np.tile(origin, (n_rays, 1)), d, t_min, draw(st.sampled_from(WIDTHS))

    def _examples(n):  # as tests/conftest.py asks: fewer under the ci profile, the profile's own otherwise
        return min(n, settings().max_examples) if settings.get_current_profile_name() == "ci" else settings().max_examples

    @settings(max_examples=_examples(25), deadline=None)
    @given(case=meshes_and_packets())
    def test_random_packets_on_random_meshes_are_bit_identical(case, device):
        tri, o, d, t_min, width = case
        mesh = (tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3))
        hits, _ = packets_change_nothing(mesh, o, d, device, t_min=t_min, t_max=2.0, bvh_width=width)
        assert_same_hits(hits, Tracer(mesh, use_bvh=False, device=device).intersect(o, d, t_min), "packets vs every primitive")


# ------------------------------------------------------------------ 7. honest visit counts
@pytest.mark.parametrize("width", WIDTHS_8_FAST)
def test_visit_counts_stay_honest_with_packets(device, width):
    mesh = lumpy_mesh(4000, seed=8)
    o, d = camera_rays([0.3, 0.4, 3.0], [0, 0, 0], 48, 32)
    nodes = Tracer(mesh, bvh_width=width, device=device)
    t, _, _ = nodes.intersect(o, d)
    hit = np.isfinite(t)
    assert 0.3 < hit.mean() < 0.9
    assert (nodes.last_visits[hit] > 0).all()  # every ray that hits visited nodes
    blocked = nodes.occluded(o, d, 10.0)
    np.testing.assert_array_equal(blocked, hit)
    assert (nodes.last_visits[blocked] > 0).all()
    tests = Tracer(mesh, count_prim_tests=True, bvh_width=width, device=device)
    np.testing.assert_array_equal(tests.intersect(o, d)[0], t)  # counting changes no answer
    assert (tests.last_visits[hit] >= 1).all()  # every hit comes from a primitive test
    assert tests.last_visits.sum() < len(o) * len(mesh[1]) / 20  # and the BVH spared most of them


@pytest.mark.slow  # four kernel builds of its own, for paths where the switch compiles to nothing
def test_width_2_and_no_bvh_answer_the_same_whichever_the_switch(device):
    """Packets walk only 8- and 4-wide trees; elsewhere the switch must change nothing at all."""
    mesh = lumpy_mesh(2000, seed=9)
    o, d = camera_rays([0.3, 0.4, 4.0], [0, 0, 0], 32, 16)
    reference = Tracer(mesh, ray_packets=True, device=device).intersect(o, d)
    for options in (dict(bvh_width=2), dict(use_bvh=False)):
        hits, _ = packets_change_nothing(mesh, o, d, device, **options)
        assert_same_hits(hits, reference, f"{options} vs 8-wide packets")
