"""Running the command line in-process from tests, and starting it as a child that tests signal."""

import signal

from clrender.cli import main


def default_sigint():
    """preexec_fn for a child that a test sends SIGINT: Python's default action, even where the suite
    itself runs with SIGINT ignored (a background job of a script), which the child would inherit and keep
    (clrender leaves an ignored SIGINT ignored, as nohup'd programs expect)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # exec keeps SIG_IGN; the new Python then installs its own


def run_cli(capsys, *argv):
    """(exit code, stdout, stderr) of `clrender ARGV`; argparse's own errors leave through SystemExit."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err
