"""Exceptions raised for bad input: the CLI turns them into one-line messages."""

from __future__ import annotations

import os


class ItensorError(Exception):
    """Base class of every error the library raises on purpose.

    The command line prints ``str(error)`` on one line and exits with status 2.
    """


class InputError(ItensorError):
    """Bad input: a missing, unreadable, empty or degenerate file or array.

    Parameters
    ----------
    path : str or os.PathLike or None
        The file the problem is in, or None for arrays passed from Python.
    message : str
        What is wrong, in a few words.
    """

    def __init__(self, path, message: str):
        self.path = None if path is None else os.fspath(path)
        self.message = message
        super().__init__(f"{self.path}: {message}" if self.path else message)


class SettingsError(ItensorError):
    """A parameter out of its valid range."""
