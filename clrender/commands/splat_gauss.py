"""Placeholder: filled in by its issue."""


def add_parsers(group):
    pass
