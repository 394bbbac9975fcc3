"""Sea trials made up: seatune's own simulator (`scenario`, its `effects` and `scenario_yaml`, for
`seatune simulate` and the sample), the log and hindcast writers, and in `independent` the independent trial path
and the blind-validation bank, which shares only the log writers."""
