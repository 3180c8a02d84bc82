"""Running the command line in-process from tests."""

from clrender.cli import main


def run_cli(capsys, *argv):
    """(exit code, stdout, stderr) of `clrender ARGV`; argparse's own errors leave through SystemExit."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err
