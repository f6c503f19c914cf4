"""Road excitation: four-wheel input spectra and time histories (docs/model.md §4).

- :mod:`hisopt.road.spectra`: wheel cross-spectral matrix, track-to-wheel delay matrix,
  left-right coherence.
- :mod:`hisopt.road.profiles`: random ISO 8608, step, bump and half-sine bump time histories.

The single-track ISO 8608 PSD itself lives in :mod:`hisopt.standards.iso_8608_2016`.
"""

from hisopt.road.profiles import bump_profile, half_sine_profile, random_profile, step_profile
from hisopt.road.spectra import isotropic_coherence, track_inputs, wheel_input_csd

__all__ = [
    "bump_profile",
    "half_sine_profile",
    "isotropic_coherence",
    "random_profile",
    "step_profile",
    "track_inputs",
    "wheel_input_csd",
]
