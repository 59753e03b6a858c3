"""The command line's error types: bad input (exit 2, one safe line) and interruptions."""

from __future__ import annotations

import re
import signal

import click

_LONG_TOKEN = re.compile(r"\S{161,}")


def clean_message(text: str, limit: int = 2000) -> str:
    """``text`` as one safe terminal line: control and format characters (newlines, a
    right-to-left override, ...) escaped, tokens over 160 characters cut in the middle,
    the whole cut to ``limit`` characters."""
    out = "".join(ch if ch.isprintable() else
                  (f"\\x{ord(ch):02x}" if ord(ch) < 0x100 else f"\\u{ord(ch):04x}"
                   if ord(ch) < 0x10000 else f"\\U{ord(ch):08x}") for ch in text)
    out = _LONG_TOKEN.sub(lambda m: f"{m[0][:100]}...[{len(m[0])} characters]..."
                          f"{m[0][-40:]}", out)
    return out if len(out) <= limit else out[:limit] + f"...[{len(out)} characters]"


class InputError(click.ClickException):
    """Bad input from the user: exit code 2, one line, nothing half-written."""

    exit_code = 2

    def show(self, file=None) -> None:
        click.echo(f"error: {clean_message(self.format_message())}", err=True, file=file)


class Interrupted(InputError):
    """Ctrl-C (exit 130) or SIGTERM (143): the runs stopped, nothing half-written."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__("interrupted")
        self.exit_code = 128 + int(signum)
