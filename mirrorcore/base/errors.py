"""Errors that mirrorscan reports to a user: one line that names what is wrong and where."""


class MirrorscanError(Exception):
    """Bad input or a request that cannot be met; the message is one line meant for the user."""


class CalibrationError(MirrorscanError):
    """A mirror plane cannot be fitted from what was given.

    Too few, collinear or invalid markers...

    Parameters
    ----------
    message : str
        One line for the user; it starts with the mirrors' names when it is about some.
    mirrors : tuple of str
        The names of the mirrors it refuses, when it is about some.

    Attributes
    ----------
    mirrors : tuple of str
        As given.
    """

    def __init__(self, message: str, mirrors: tuple[str, ...] = ()):
        super().__init__(message)
        self.mirrors = tuple(mirrors)


class FileFormatError(MirrorscanError):
    """A file (session, depth image, PLY, intrinsics, scene) is missing, unreadable or malformed."""


class Cancelled(MirrorscanError):
    """A long computation (carving, fusion) was stopped by its caller's cancel request.

    Nothing was returned.
    """
