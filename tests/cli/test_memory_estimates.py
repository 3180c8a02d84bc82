"""What memory.render_bytes and the texture check count (issue 38, defect 6): --denoise (OIDN's working
memory, 742 B/pixel measured at 1024^2: a 1024^2 render under --max-memory 600M peaked at 1,094 MB and exited 0),
and textures at what decoding peaks at (memory.TEXEL_BYTES, 56 B/texel: a 6000^2 texture under 1300M peaked
at 1,835 MB), with the interpreter's base, and again with the render."""

import importlib.util

import numpy as np
import pytest
from PIL import Image

from clrender import memory

from tests.clitools import run_cli

needs_oidn = pytest.mark.skipif(importlib.util.find_spec("pyoidn") is None, reason="pyoidn is not installed")


def test_the_estimate_counts_denoise_and_textures():
    base = memory.render_bytes(1024, 1024, aovs=2, extra_images=2)
    assert memory.render_bytes(1024, 1024, aovs=2, extra_images=2, denoise=True) - base == 1024 * 1024 * memory.DENOISE_BYTES_PER_PIXEL
    assert memory.DENOISE_BYTES_PER_PIXEL >= 742  # measured peak RSS growth of OIDN (quality high) at 1024^2
    assert memory.render_bytes(64, 64, texels=6000**2) - memory.render_bytes(64, 64) == 6000**2 * memory.TEXEL_BYTES
    assert memory.TEXEL_BYTES >= 35 + 16  # decoding's measured peak, then the device copy


@needs_oidn
def test_a_denoised_render_past_max_memory_is_refused_before_rendering(capsys, tmp_path):
    """The red team's case: 1024^2, --denoise, --max-memory 600M: refused (it rendered and peaked at 1,094 MB)."""
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "--max-memory", "600M", "render", "refract1", "--integrator", "path", "--spp", "1",
                           "--denoise", "--width", "1024", "--height", "1024", "-o", str(out))  # fmt: skip
    budget = "--max-memory is 600 MiB" in err or "is available" in err  # the smaller of the two is named
    assert code == 2 and len(err.strip().splitlines()) == 1 and "1024x1024" in err and budget, err
    assert not out.exists()


def test_a_6000_texture_under_1300m_is_refused_before_decoding(capsys, tmp_path):
    """The red team's 6000^2 texture under --max-memory 1300M: 256 MiB + 36 M texels x 56 B = 2.1 GiB, refused
    from the header (it was accepted at 32 B/texel apart from the base, and peaked at 1,835 MB)."""
    Image.fromarray(np.zeros((6000, 6000), np.uint8)).save(tmp_path / "t.png")
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[textures.t]\nfile = "t.png"\n[materials.m]\ndiffuse_texture = "t"\n'
        '[[objects]]\ntype = "quad"\ncorner = [-1, -1, -3]\nedge_a = [2, 0, 0]\nedge_b = [0, 2, 0]\nmaterial = "m"\n'
    )
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "--max-memory", "1300M", "render", str(scene), "--width", "8", "--height", "8", "-o", str(out))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "6000 x 6000" in err and "2.1 GiB" in err, err
    assert not out.exists()
