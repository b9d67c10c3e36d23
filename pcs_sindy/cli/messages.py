"""What a command says: one place for the messages of every command (logging when the command line set it up).

Imports nothing of the package: the commands, the contact sheet and the demo all use it.
"""

from __future__ import annotations

__all__ = ["say"]


def say(quiet: bool, text: str) -> None:
    """A message of a command: logged (logger ``pcs_sindy.cli``) under the command line, else printed."""
    if quiet:
        return
    import logging

    if logging.getLogger("pcs_sindy").handlers:  # the command line's (pcs_sindy.cli.main)
        logging.getLogger("pcs_sindy.cli").info(text)
    else:  # a command called from Python: print, as a script expects
        print(text)
