"""Estimators from measurements: effective RAOs (`rao_estimation`), natural frequencies (`natural_frequency`) and
the directional sea from the ship's own motions (`sea_estimation`). They read the model (`seatune.physics`) and
never the stages."""
