"""tools/kernel_profile.py: perf samples of render_path's code, shared out by the inline chains the line table gives."""

import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tools import kernel_profile  # noqa: E402


def test_shares_count_a_sample_once_per_function_on_its_chain_and_once_innermost():
    chains = {
        0x10: [("triangle_test4", "/k/triangle.h:22:5"), ("hit_block", "/k/intersect.h:300:1"), ("render_path", "path.cl:690:3")],
        0x20: [("dot3", "/k/common.h:71:2"), ("dot3", "/k/common.h:71:2"), ("render_path", "path.cl:500:1")],  # dot3 inlined in dot3
        0x30: [],  # an offset the line table does not cover
    }
    tables = kernel_profile.shares(Counter({0x10: 3, 0x20: 2, 0x30: 1}), chains)
    assert tables["group"] == Counter()  # no walk or sampler on these chains
    assert tables["inclusive"] == Counter({"render_path": 5, "triangle_test4": 3, "hit_block": 3, "dot3": 2, "?": 1})
    assert tables["function"] == Counter({"triangle_test4": 3, "dot3": 2, "?": 1})
    assert tables["file"] == Counter({"triangle.h": 3, "common.h": 2, "?": 1})
    assert tables["line"] == Counter({"triangle.h:22": 3, "common.h:71": 2, "?:0": 1})
    assert sum(tables["function"].values()) == sum(tables["file"].values()) == 6  # every sample once innermost


def test_without_perf_it_says_what_to_install_and_exits_2(monkeypatch, capsys):
    monkeypatch.setattr(kernel_profile.shutil, "which", lambda tool: None)
    assert kernel_profile.main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "perf and llvm-symbolizer" in err


def test_a_group_counts_a_sample_once_when_several_of_its_functions_are_on_the_chain():
    chains = {
        0x10: [("mix32", "/k/rng.h:16:1"), ("rng_next", "/k/rng.h:80:1"), ("rng_next2", "/k/rng.h:90:1"), ("render_path", "path.cl:1:1")],
        0x20: [("sobol_value2", "/k/sobol.h:90:1"), ("rng_next2", "/k/rng.h:90:1"), ("render_path", "path.cl:1:1")],
        0x30: [("hit_boxes", "/k/intersect.h:376:1"), ("mesh_walk_any", "/k/ray_walks.h:1:1"), ("render_path", "path.cl:1:1")],
    }
    tables = kernel_profile.shares(Counter({0x10: 3, 0x20: 2, 0x30: 4}), chains)
    assert tables["group"] == Counter({"the sampler": 5, "any-hit walks": 4})
