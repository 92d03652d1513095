"""Between-capture reproducibility (hil.diagnosis.reproducibility): a term fixed within each
capture but different between captures is in no capture's revolution scatter; repeated bases
measure it, and the standard additions' uncertainty then covers it."""

import numpy as np
import pytest

from hil.diagnosis import reproducibility
from hil.diagnosis.additions import diagnose_by_additions, with_addition
from hil.diagnosis.orders import OrderSpectrum

P = 2                                   # pole pairs: orders 2 (offsets), 4 (gain), 12 (dead time)
H_A, H_B = 0.05 * np.exp(0.9j), 0.05 * np.exp(-0.1j)
SIGMA_A = 1e-6                          # each capture's type A (revolution scatter), N·m


def _spectrum(label, offsets, capture_term, addition):
    c = np.zeros(30, dtype=complex)
    c[0] = 1.0
    c[2] = H_A * offsets[0] + H_B * offsets[1] + capture_term
    s = OrderSpectrum(label=label, speed_rpm=1000.0, current_a=20.0, current_angle_rad=0.0,
                      pole_pairs=P, coefficients_nm=c, sigma_nm=np.full(30, SIGMA_A),
                      revolutions=8)
    return with_addition(s, dict(addition, label=label))


def _captures(rng, s_r, *, repeat: bool):
    """A drive with offsets (0.1, −0.05) A; every capture adds its own term of σ = s_r per
    component at order 2 (fixed within the capture)."""
    def term():
        return complex(*rng.normal(0.0, s_r, 2))
    out = [_spectrum("base", (0.1, -0.05), term(), {}),
           _spectrum("a+0.2", (0.3, -0.05), term(), {"addition_ia_offset_a": 0.2}),
           _spectrum("a+0.4", (0.5, -0.05), term(), {"addition_ia_offset_a": 0.4}),
           _spectrum("b+0.2", (0.1, 0.15), term(), {"addition_ib_offset_a": 0.2})]
    if repeat:
        out += [_spectrum("base again", (0.1, -0.05), term(), {}),
                _spectrum("base third", (0.1, -0.05), term(), {})]
    return out


def test_the_scatter_of_repeated_captures_less_their_type_a_is_s_r():
    rng = np.random.default_rng(3)
    groups = []
    for k in range(40):
        spectra = [_spectrum(f"p{k}", (0.0, 0.0), complex(*rng.normal(0, 2e-5, 2)), {})
                   for _ in range(2)]
        groups.append((f"p{k}", spectra))
    found = reproducibility.estimate(groups, [2, 4])
    assert found.dof == 80
    assert found.sigma_nm[2] == pytest.approx(2e-5, rel=0.25)        # 80 dof: ±16 % (1 σ)
    assert found.sigma_nm[4] == 0.0                                   # nothing there
    applied = reproducibility.applied(groups[0][1][0], found)
    assert applied.sigma_nm[2] == pytest.approx(np.hypot(SIGMA_A, found.sigma_nm[2]))
    assert applied.sigma_nm[3] == SIGMA_A
    assert reproducibility.estimate([("one", groups[0][1][:1])], [2]) is None


def test_a_transfers_u_covers_a_capture_to_capture_term_only_with_repeated_bases():
    """A term of 20 type-A σ that changes between captures: without repeated bases the offset
    transfer's u ignores it (|error|/u within 2.45, the 95 % radius of two components, in
    almost no trial); with two more bases (4 dof for s_R) it is covered in most trials (fewer
    than 95 %: s_R from 4 dof has wide tails)."""
    rng = np.random.default_rng(7)
    covered = {False: [], True: []}
    for _ in range(60):
        for repeat in (False, True):
            result = diagnose_by_additions(_captures(rng, 20 * SIGMA_A, repeat=repeat),
                                           tolerance_pu=0.0)
            (transfer,) = [t for t in result.transfers if t["addition"] == "addition_ia_offset_a"]
            error = abs(transfer["transfer"] - H_A) / transfer["standard_uncertainty"]
            covered[repeat].append(error <= 2.45)
    assert np.mean(covered[False]) < 0.1
    assert np.mean(covered[True]) >= 0.7
    result = diagnose_by_additions(_captures(rng, 20 * SIGMA_A, repeat=False), tolerance_pu=0.0)
    assert any("reproducibility NOT estimated" in note for note in result.notes)
    assert result.to_dict()["reproducibility"] is None
    repeated = diagnose_by_additions(_captures(rng, 20 * SIGMA_A, repeat=True), tolerance_pu=0.0)
    assert repeated.to_dict()["reproducibility"]["dof"] == 4
