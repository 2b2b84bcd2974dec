"""Errors and warnings shared by the recording readers."""

from __future__ import annotations


class RecordingError(ValueError):
    """A recording that cannot be read: missing, empty, truncated before its first intact
    ping, of the wrong format, or without a port/starboard side-scan pair. The message
    names the file and what was wrong; the CLI prints it and exits with code 2."""


class TruncatedRecordingWarning(UserWarning):
    """A recording ended inside a ping: the intact pings before it were kept, the rest
    dropped. The message names the file and both counts."""
