"""Exception hierarchy of repulsionpak.

Every error a user can cause derives from :class:`RepulsionPakError`; the CLI turns
these into one line on stderr and a non-zero exit code (see ``cli.EXIT_CODES``).
"""

from __future__ import annotations

from pathlib import Path


class RepulsionPakError(Exception):
    """Base class of every error raised on purpose by repulsionpak."""

    exit_code = 1


class InputError(RepulsionPakError):
    """An input file cannot be used (missing, unreadable, malformed, no geometry ...).

    ``path`` names the file; the message says what is wrong and, where possible,
    what to do about it.
    """

    exit_code = 2

    def __init__(self, path: str | Path | None, problem: str):
        self.path = None if path is None else str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}" if self.path else problem)


class ParameterError(RepulsionPakError, ValueError):
    """A parameter (command-line option, config key or API argument) is invalid."""

    exit_code = 3


class ConfigError(ParameterError):
    """A TOML configuration file is malformed or has unknown keys / wrong types."""


class SimulationError(RepulsionPakError):
    """The simulation could not produce a valid packing (e.g. it diverged)."""

    exit_code = 4


class DivergedError(SimulationError):
    """Positions or velocities became NaN/inf or exploded and could not be recovered."""


class OutputError(RepulsionPakError):
    """An output cannot be written (would overwrite an input, unwritable directory ...)."""

    exit_code = 5
