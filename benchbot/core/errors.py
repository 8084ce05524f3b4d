"""Errors raised by BenchBot's core, and the CLI's exit codes.

Every error carries a one-line ``message`` (what is wrong, naming the file/field) and a ``hint`` (how to fix it).
The CLI prints ``error: <message>`` and ``hint: <hint>`` and exits with the code of the error class; a traceback
is shown only when the environment variable ``BENCHBOT_DEBUG=1`` is set.
"""

from __future__ import annotations

import enum


class ExitCode(enum.IntEnum):
    """Exit codes of the ``benchbot`` command."""

    OK = 0
    FAILURE = 1  # an episode, a submission or an evaluation failed
    USAGE = 2  # bad flags or arguments
    SPEC = 3  # a task/robot/environment/... specification is invalid or missing
    RESULTS = 4  # a results file is malformed
    BACKEND = 5  # the backend (simulator, robot, server) failed
    INTERRUPTED = 130


class BenchbotError(Exception):
    """Base class of every error BenchBot reports to users.

    Args:
        message: one line saying what is wrong, naming the file and field where there is one.
        hint: one line saying how to fix it (may be empty).
    """

    exit_code = ExitCode.FAILURE

    def __init__(self, message: str, hint: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.hint = hint

    def __str__(self) -> str:
        return self.message


class UsageError(BenchbotError):
    """A command-line flag or argument is wrong."""

    exit_code = ExitCode.USAGE


class SpecError(BenchbotError):
    """A specification (task, robot, environment, format, evaluator, example, batch, ground truth) is invalid,
    missing, or clashes with another."""

    exit_code = ExitCode.SPEC


class ResultsError(BenchbotError):
    """A results file is unreadable or does not follow its format."""

    exit_code = ExitCode.RESULTS


class BackendError(BenchbotError):
    """The robot backend, the simulator or the backend server failed."""

    exit_code = ExitCode.BACKEND


class RobotFaultError(BackendError):
    """The robot stopped itself on a fault it detected (a sensor topic silent past its limit, TF lost, no fresh
    observation): the robot is safe and the backend still runs, so the server answers 503 (never 500: a fault of
    the robot, not of BenchBot) and the client shows the message as one line. The message names the topic or frame
    and the setting that sets the limit."""


class ActionError(BenchbotError):
    """An action was refused by the episode (not allowed by the task, robot collided, trajectory finished)."""

    exit_code = ExitCode.FAILURE
