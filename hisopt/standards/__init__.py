"""Standards, one module per standard named with its number and year.

- :mod:`hisopt.standards.iso_2631_1_1997`: whole-body vibration frequency weightings.
- :mod:`hisopt.standards.iso_8608_2016`: road-profile displacement spectra and classes.
- :mod:`hisopt.standards.weighting_filters`: the ISO 2631-1 weightings as realisable filters
  on sampled records (the time domain).
"""
