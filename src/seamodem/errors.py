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
    """

    def __init__(self, parameter: str, message: str):
        self.parameter = parameter
        super().__init__(f"{parameter}: {message}")


class InputFileError(SeamodemError, OSError):
    """A missing, unreadable, empty, truncated or inconsistent input file."""


class PayloadError(SeamodemError, ValueError):
    """A payload that does not fit the frame or cannot be encoded."""
