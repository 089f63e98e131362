"""The two kinds of failure frictionid reports: bad input (exit 2) and a failure inside a computation (exit 1)."""


class InputError(ValueError):
    """Input that cannot be used as given.

    The message names where the problem is (file, line, column, key or model entity) and what was expected.
    The command line turns it into exit status 2 without a traceback.
    """


class SolverError(RuntimeError):
    """A computation that did not succeed on valid input (e.g. a contact increment that does not converge)."""
