"""Blind validation of seatune on the independent trial bank (issue 15): scoring and the bank page."""
