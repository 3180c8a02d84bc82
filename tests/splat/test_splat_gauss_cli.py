"""`clrender splat gauss|render|sweep` end to end on a tiny image, and their bad-input errors (exit 2)."""

import csv

import numpy as np
import pytest

from clrender.cli import main
from clrender.image.files import read_image, write_image
from clrender.splat.gauss import GaussParams


@pytest.fixture
def photo(tmp_path):
    ys, xs = np.mgrid[0:40, 0:56] / 40.0
    img = np.stack([xs / 1.4, ys, 0.5 + 0.4 * np.sin(6 * xs) * np.cos(5 * ys)], axis=-1)
    path = tmp_path / "in.png"
    write_image(path, img.astype(np.float32))
    return path


def test_gauss_writes_image_params_log_and_curve(tmp_path, photo):
    out = tmp_path / "out.png"
    rc = main(
        [
            "-q",
            "splat",
            "gauss",
            str(photo),
            "-o",
            str(out),
            "--splats",
            "40",
            "--epochs",
            "30",
            "--save-params",
            str(tmp_path / "p.npz"),
            "--log",
            str(tmp_path / "log.csv"),
        ]
    )
    assert rc == 0
    fitted = read_image(out).pixels
    assert fitted.shape == (40, 56, 3)
    assert (tmp_path / "out.curve.png").is_file()
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    assert float(rows[-1]["psnr"]) > float(rows[0]["psnr"]) and int(rows[-1]["step"]) == 30
    params = GaussParams.load(tmp_path / "p.npz")
    assert params.n == 40 and (params.width, params.height) == (56, 40)
    # re-render at twice the width
    assert main(["splat", "render", str(tmp_path / "p.npz"), "-o", str(tmp_path / "big.png"), "--width", "112"]) == 0
    assert read_image(tmp_path / "big.png").pixels.shape == (80, 112, 3)


def test_sweep_reports_the_best(tmp_path, photo, capsys):
    rc = main(
        [
            "-q",
            "splat",
            "sweep",
            str(photo),
            "--splats",
            "20",
            "--epochs",
            "5",
            "--lrs",
            "0.5",
            "2",
            "--batches",
            "0",
            "512",
            "--csv",
            str(tmp_path / "sweep.csv"),
        ]
    )
    assert rc == 0
    out = capsys.readouterr().out
    assert out.count("PSNR") == 5 and "best: --lr" in out
    assert len(list(csv.DictReader(open(tmp_path / "sweep.csv")))) == 4


@pytest.mark.parametrize(
    "args, message",
    [
        (["--splats", "0"], "--splats 0"),
        (["--epochs", "-1"], "--epochs -1"),
        (["--lr", "0"], "--lr 0"),
        (["--batch", "-5"], "--batch -5"),
        (["--max-splats", "3", "--splats", "10"], "--max-splats 3"),
        (["--time-budget", "0"], "--time-budget 0"),
        (["--init", "spiral"], "invalid choice"),
        (["--loss", "l3"], "invalid choice"),
        (["--save-params", "p.txt"], ".npz"),
    ],
)
def test_gauss_bad_input_exits_2_and_writes_nothing(tmp_path, photo, capsys, args, message):
    out = tmp_path / "out.png"
    try:
        rc = main(["splat", "gauss", str(photo), "-o", str(out), *args])
    except SystemExit as exc:  # argparse's own errors (invalid choice) leave through SystemExit
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err
    assert message in err and err.startswith("clrender: ") and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.png"]


def test_gauss_refuses_non_image_and_existing_output(tmp_path, photo, capsys):
    text = tmp_path / "notes.txt"
    text.write_text("not an image")
    assert main(["splat", "gauss", str(text), "-o", str(tmp_path / "o.png")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["splat", "gauss", str(photo), "-o", str(photo)]) == 2
    assert "is the input" in capsys.readouterr().err
    assert not (tmp_path / "o.png").exists()


def test_render_refuses_bad_params_file(tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, xy=np.zeros((1, 2)))
    assert main(["splat", "render", str(bad), "-o", str(tmp_path / "o.png")]) == 2
    assert "not a splat parameter file" in capsys.readouterr().err
    assert main(["splat", "render", str(tmp_path / "missing.npz"), "-o", str(tmp_path / "o.png")]) == 2
