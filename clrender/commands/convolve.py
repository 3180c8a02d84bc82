"""Placeholder: filled in by its issue."""


def add_parser(sub):
    pass
