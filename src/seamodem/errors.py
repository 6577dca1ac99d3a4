"""Exceptions raised by seamodem.

Every error names the parameter (or file) at fault, the limit and the value
given, in one line, so the command line can print it without a traceback.
"""


class SeamodemError(Exception):
    """Base class of the errors the command line reports as one line."""


class ConfigError(SeamodemError, ValueError):
    """An invalid configuration value.

    Parameters
    ----------
    parameter : str
        Name of the offending parameter, as spelled in the configuration.
    message : str
        What is wrong: the limit and the value given.
    file : str or Path, optional
        The file the value was read from, named first in the message.
    """

    def __init__(self, parameter: str, message: str, *, file=None):
        self.parameter = parameter
        self.message = message
        self.file = file
        super().__init__(f"{parameter}: {message}" if file is None else f"{file}: {parameter}: {message}")

    def in_file(self, file) -> "ConfigError":
        """The same error, the file it was read from named first."""
        return ConfigError(self.parameter, self.message, file=file)


def value_text(value, limit: int = 40) -> str:
    """A value as an error message quotes it: its repr, cut to ``limit`` characters (never a file's contents)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


class InputFileError(SeamodemError, OSError):
    """A missing, unreadable, empty, truncated or inconsistent input file."""


class PayloadError(SeamodemError, ValueError):
    """A payload that does not fit the frame or cannot be encoded."""
