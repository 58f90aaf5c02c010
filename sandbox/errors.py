"""The project's one exception type."""


class SandboxError(Exception):
    """An error a user can act on: bad input, a failed run, a missing resource.

    The message names the file, the item and what is wrong. The CLI prints it without a
    traceback and exits with status 2.
    """
