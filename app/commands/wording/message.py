"""A message of the command line: a headline, then the figures behind it.

Every message is a headline of at most HEADLINE_WORDS words (what happened, what to do), then the
figures behind it, which the commands print indented under it with `-v/--verbose`."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TextIO

import numpy as np

HEADLINE_WORDS = 25
INDENT = "  "


@dataclass(frozen=True)
class Message:
    """A headline (at most HEADLINE_WORDS words) and the lines of figures behind it.

    Attributes
    ----------
    headline : str
        What happened and what to do.
    details : tuple of str
        The figures behind it, printed under `-v/--verbose`.
    """

    headline: str
    details: tuple[str, ...] = ()

    def lines(self, verbose: bool) -> list[str]:
        """The headline, then with `verbose` each detail indented by INDENT.

        Parameters
        ----------
        verbose : bool
            Add the details after the headline.

        Returns
        -------
        list of str
            The lines to print.
        """
        return [self.headline, *(INDENT + d for d in self.details if verbose)]


def show(message: Message, verbose: bool, file: TextIO | None = None) -> None:
    """Print the message's lines (see Message.lines) to `file`.

    Parameters
    ----------
    message : Message
        What to print.
    verbose : bool
        Print its details too.
    file : TextIO, optional
        Where to print; stdout by default. Flushed after writing.
    """
    print("\n".join(message.lines(verbose)), file=file or sys.stdout, flush=True)


def plane_figures(abcd) -> str:
    """The plane's coefficients a, b, c, d, rounded to 5 decimals.

    Parameters
    ----------
    abcd : array_like, shape (4,)
        The plane ax + by + cz + d = 0 (metres).

    Returns
    -------
    str
        The list of the four rounded figures.
    """
    return str(np.round(np.asarray(abcd, dtype=float), 5).tolist())
