"""An independent trial path for blind validation (issue 15).

Nothing in this package imports seatune's estimator (``seatune.physics``, ``tuning``, ``diagnosis``,
``pipeline``): RAOs come straight from Capytaine (``capytaine.post_pro.rao``), seas from wavespectra's
constructors, hidden effects from their own mechanisms, sensors from geometry, and the hindcast is written
by this package's own ERA5 writer. Only ``seatune.simulate.log_writers`` (MCAP / CSV) and ``seatune.atomic``
are shared, and they hold no modelling choices.

Modules: ``hulls`` (the second hull's per-draft Capytaine datasets), ``hydro`` (truth RAOs, coupled roots,
extra DOFs), ``seas`` (partitions and directional spectra), ``era5`` (degraded hindcast writer),
``trial`` (one trial: synthesis, effects, sensors, files), ``bank`` (the bank definition and generator).
"""
