"""`--help` of every command and subcommand: each option has a help line that states its default
exactly once, in words a user can act on (never "None" or "[]"), and --help itself exits 0."""

import argparse
import subprocess
import sys

import pytest

from clrender.cli import build_parser


def all_parsers():
    """(command words, parser) for the top level and every subcommand, walking the argparse tree."""
    found = []

    def walk(words, parser):
        found.append((words, parser))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(words + (name,), sub)

    walk((), build_parser())
    return found


PARSERS = all_parsers()
IDS = [" ".join(words) or "clrender" for words, _ in PARSERS]


def shown_help(parser, action) -> str:
    """The help text exactly as --help prints it for this action (defaults appended, %-expanded)."""
    return parser._get_formatter()._expand_help(action)


def test_the_tree_has_every_command():
    assert {" ".join(w) for w, _ in PARSERS} >= {
        "",
        "render",
        "convolve",
        "devices",
        "splat",
        "splat gauss",
        "splat render",
        "splat sweep",
        "splat voronoi",
    }


@pytest.mark.parametrize("words,parser", PARSERS, ids=IDS)
def test_every_option_has_help_and_its_default_once(words, parser):
    problems = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = "/".join(action.option_strings) or action.dest
        if not action.help or action.help == argparse.SUPPRESS:
            problems.append(f"{name}: no help line")
            continue
        text = shown_help(parser, action)
        if isinstance(action, argparse._VersionAction):
            continue
        if not action.option_strings or action.required:
            # a positional or a required option is given or missing: it must not pretend to have a default
            if "(default:" in text:
                problems.append(f"{name}: a positional shows a default: {text!r}")
            continue
        count = text.lower().count("default")
        if count != 1:
            problems.append(f"{name}: 'default' appears {count} times in {text!r}")
        for meaningless in ("(default: None)", "(default: [])", "default: ==SUPPRESS=="):
            if meaningless in text:
                problems.append(f"{name}: shows {meaningless!r}")
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("words", [w for w, _ in PARSERS], ids=IDS)
def test_help_exits_zero_and_prints_to_stdout(words, capsys):
    from clrender.cli import main

    assert main([*words, "--help"]) == 0
    out = capsys.readouterr()
    assert out.out.startswith("usage: clrender") and out.err == ""


def test_help_shows_a_worked_example_for_commands_that_do_work():
    for words, parser in PARSERS:
        if words and words != ("splat",):
            assert "example" in parser.format_help(), f"{' '.join(words)} --help has no example"


def test_every_kernel_running_command_takes_device():
    kernel_commands = {("render",), ("devices",), ("splat", "gauss"), ("splat", "render"), ("splat", "sweep"), ("splat", "voronoi")}
    for words, parser in PARSERS:
        if words in kernel_commands:
            assert any("--device" in a.option_strings for a in parser._actions), " ".join(words)


def test_help_in_a_subprocess_is_the_same_program():
    # the console entry point, not only main(): --help exits 0 with the usage on stdout
    proc = subprocess.run([sys.executable, "-m", "clrender", "splat", "voronoi", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0 and "--init" in proc.stdout and proc.stderr == ""
