"""ripple-hil: bench tests of controller-induced torque ripple in PMSM drives.

Reference: S. Chen, C. Namuduri, S. Mir, "Controller-Induced Parasitic Torque Ripples in a PM
Synchronous Motor", IEEE Trans. Ind. Appl., 38(5), 2002 (called "the paper" throughout).
"""

__version__ = "0.1.0"
