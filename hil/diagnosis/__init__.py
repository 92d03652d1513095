"""Ripple diagnosis: the inverse of ``hil.model`` (design.md §8, issue 15).

From measured torque order spectra (amplitude and phase, per mechanical order) at one or more
operating points, estimate each ripple source's parameters — sensor offsets Δa, Δb (A), the gain
difference k_a − k_b, the effective dead time (µs), the encoder's resolution, motor-side cogging
and EMF-harmonic torque — with standard uncertainties and correlations, say what the captures
cannot separate and which extra point would, and what calibration would remove the ripple::

    spectra = spectra_from_captures([(capture, {"current_a": 20.0, "label": "20 A"}), ...])
    result = diagnose(spectra, setup=DriveSetup(current_loop_bandwidth_hz=1600.0,
                                                current_loop_delay_s=75e-6,
                                                transducer_bandwidth_hz=1000.0))
    print(result.table()); record.set_section("diagnosis", result.to_dict())

The fit uses the forward models (``hil.model`` and the derived forms in :mod:`.signatures`), never
the twin.
"""

from hil.diagnosis.core import diagnose, spectra_from_captures
from hil.diagnosis.orders import OrderSpectrum, spectrum_from_capture
from hil.diagnosis.result import Diagnosis, ParameterEstimate
from hil.diagnosis.signatures import DriveSetup

__all__ = ["Diagnosis", "DriveSetup", "OrderSpectrum", "ParameterEstimate", "diagnose",
           "spectra_from_captures", "spectrum_from_capture"]
