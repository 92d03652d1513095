"""Error types shared by every layer. Each message names what was being done and why it failed."""


class HilError(Exception):
    """Base class of every error ripple-hil raises on purpose."""


class InputError(HilError, ValueError):
    """Bad input from a user: a CLI option, a bench-file key, an injection value, a capture file.

    The message names the option or key, the bad value and the allowed range. The CLI prints it
    on one line to stderr and exits with code 2.
    """
