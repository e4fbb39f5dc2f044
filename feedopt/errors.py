"""Error types that map to the command-line exit codes.

``InputError`` is bad user input (exit code 2): the message must say what is wrong, where
(field path, sample index, corner index, ...) and, when there is one, what would work.
Anything else that escapes is an internal error (exit code 1).
"""


class FeedoptError(Exception):
    """Base class of feedopt's own errors."""


class InputError(FeedoptError):
    """The user's input cannot be planned; the message says why and where (exit code 2)."""


class VerificationError(FeedoptError):
    """A trajectory failed its own replay verification and must not be exported silently."""
