"""Errors that reach the user as one line and exit code 2 (DESIGN §1)."""

from __future__ import annotations


class UserError(Exception):
    """Bad input: the message names the file, the place and the problem."""

    def __init__(self, source: str | None, place: str | None, problem: str):
        self.source, self.place, self.problem = source, place, problem
        where = ": ".join(p for p in (source, place) if p)
        super().__init__(f"{where}: {problem}" if where else problem)

    def __reduce__(self):  # from a worker process (seatune.parallel) the error comes back pickled
        return type(self), (self.source, self.place, self.problem)
