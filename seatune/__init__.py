"""seatune: tuned, uncertainty-quantified seakeeping models from logged sea trials."""

__version__ = "0.1.0"
