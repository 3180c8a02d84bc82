"""One Mitsuba 3 XML file rendered by Mitsuba and by clrender (`Scene.from_file`), compared by the block z-test.

The scene is the Cornell box as Mitsuba's tutorial writes it: OBJ walls, `twosided` `diffuse` BSDFs by `ref`,
an `area` emitter on a `rectangle`, a `cube`, a `dielectric` sphere, a `conductor` sphere (Mitsuba's default
`none`, a perfect mirror), a `perspective` sensor with
`fov_axis` x, `$spp` and `<default>`; the file's `max_depth` 8 is clrender's 6.  Mitsuba loads the very file
(mi.load_file); the test is tests/reference/ztest.py (8 x 8 blocks, K = 4 renders a side, Šidák at alpha 0.01).
Slow, and skipped without Mitsuba.
"""

import numpy as np
import pytest

from tests.reference import mitsuba_scenes
from tests.reference.ztest import two_sample_z

K, SPP, WIDTH, HEIGHT = 4, 64, 64, 48  # not square: fov_axis x matters
WALLS = {  # name: four corners, counter-clockwise seen from inside the box
    "floor": [(-1, -1, -1), (-1, -1, 1), (1, -1, 1), (1, -1, -1)],
    "ceiling": [(-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)],
    "back": [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)],
    "left": [(-1, -1, -1), (-1, 1, -1), (-1, 1, 1), (-1, -1, 1)],
    "right": [(1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1)],
}
COLOURS = {"floor": "white", "ceiling": "white", "back": "white", "left": "red", "right": "green"}

CBOX = """<scene version="3.0.0">
    <default name="spp" value="16"/>
    <integrator type="path"><integer name="max_depth" value="8"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="39.3077"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world"><lookat origin="0, 0, 4.2" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/><integer name="height" value="{height}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.885809, 0.698859, 0.666422"/></bsdf></bsdf>
    <bsdf type="twosided" id="red"><bsdf type="diffuse"><rgb name="reflectance" value="0.570068, 0.0430135, 0.0443706"/></bsdf></bsdf>
    <bsdf type="twosided" id="green"><bsdf type="diffuse"><rgb name="reflectance" value="0.105421, 0.37798, 0.076425"/></bsdf></bsdf>
    {walls}
    <shape type="rectangle">
        <transform name="to_world"><scale x="0.25" y="0.2"/><rotate x="1" angle="90"/><translate y="0.99"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="18.387, 13.9873, 6.75357"/></emitter>
    </shape>
    <shape type="cube">
        <transform name="to_world"><scale value="0.3"/><rotate y="1" angle="20"/><translate x="0.35" y="-0.7" z="-0.3"/></transform>
        <ref id="white"/>
    </shape>
    <shape type="sphere">
        <point name="center" x="-0.4" y="-0.65" z="0.3"/><float name="radius" value="0.35"/>
        <bsdf type="dielectric"/>
    </shape>
    <shape type="sphere">
        <transform name="to_world"><scale value="0.25"/><translate x="0.45" y="-0.15" z="0.2"/></transform>
        <bsdf type="conductor"/>
    </shape>
</scene>
"""


def write_cbox(folder):
    lines = []
    for name, corners in WALLS.items():
        (folder / f"{name}.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners) + "f 1 2 3\nf 1 3 4\n")
        lines.append(f'<shape type="obj"><string name="filename" value="{name}.obj"/><ref id="{COLOURS[name]}"/></shape>')
    path = folder / "cbox.xml"
    path.write_text(CBOX.format(width=WIDTH, height=HEIGHT, walls="\n    ".join(lines)))
    return path


@pytest.mark.slow
def test_cornell_box_xml_matches_mitsuba(tmp_path, device):
    variant = "llvm_ad_rgb" if not mitsuba_scenes.unavailable("llvm_ad_rgb") else "scalar_rgb"
    reason = mitsuba_scenes.unavailable(variant)
    if reason:
        pytest.skip(reason)
    mi = mitsuba_scenes.load_mitsuba(variant)
    path = write_cbox(tmp_path)
    loaded = mi.load_file(str(path), spp=SPP)
    theirs = np.stack([mitsuba_scenes.render_loaded(mi, loaded, spp=SPP, seed=100 + s) for s in range(K)])

    from clrender import Renderer
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    scene = Scene.from_file(path, defines={"spp": str(SPP)})
    own = scene.render_settings
    assert own == {"integrator": "path", "max_depth": 6, "spp": SPP, "rfilter": "box", "path_sampler": "independent"}
    tracer = Tracer(scene, device=device)
    ours = np.stack([Renderer(scene, tracer=tracer, integrator="path", spp=SPP, max_depth=own["max_depth"], seed=s).run().image for s in range(K)])
    result = two_sample_z(ours, theirs)
    assert result.passed, result.report()
