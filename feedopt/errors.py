"""Error types that map to the command-line exit codes.

``InputError`` is bad user input (exit code 2): the message must say what is wrong, where
(field path, sample index, corner index, ...) and, when there is one, what would work.
Anything else that escapes is an internal error (exit code 1).
"""


class FeedoptError(Exception):
    """Base class of feedopt's own errors."""


class InputError(FeedoptError):
    """The user's input cannot be planned; the message says why and where (exit code 2)."""


class LawNotApplicable(FeedoptError):
    """A timing law declines a problem it was not made for (the reason is the message).

    Not bad input: the other laws plan the same problem. The runner records the law as
    declined, says why, and goes on with the others.
    """


class Terminated(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an error
    """The process received SIGTERM or SIGHUP: unwind (cleaning up staging folders) and stop.

    A ``BaseException`` like :class:`KeyboardInterrupt`, so that no ``except Exception``
    swallows it and every ``finally`` on the way out runs.
    """

    def __init__(self, signal_name: str, signal_number: int) -> None:
        super().__init__(signal_name)
        self.signal_name = signal_name
        self.signal_number = signal_number
