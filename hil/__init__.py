"""ripple-hil: bench tests of controller-induced torque ripple in PMSM drives.

Reference: S. Chen, C. Namuduri, S. Mir, "Controller-Induced Parasitic Torque Ripples in a PM
Synchronous Motor", IEEE Trans. Ind. Appl., 38(5), 2002 (called "the paper" throughout).

PYTEST_DONT_REWRITE: library code, not tests. pytest marks every package of an installed
distribution that ships a pytest plugin for assertion rewriting; ``hil run`` runs pytest from
inside this package, so it is always imported first (issue 22.9: a warning on every run).
"""

__version__ = "0.1.0"
