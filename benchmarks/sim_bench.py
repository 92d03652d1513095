"""Benchmark of the digital twin: wall seconds per simulated second (target <= 0.02, i.e. 50x
faster than real time), for the full non-ideal drive on one core and for a batch of 16 sets.

Run: ``.venv/bin/python benchmarks/sim_bench.py [--seconds S] [--daq-rate-hz R]``.
"The full non-ideal drive": every injection knob on (20 kHz PWM with 2000 counts, dead time 1 µs,
both current-sensor offsets and gain errors, encoder decimation 10, 16-bit fixed-point firmware,
φ = 0.2 rad) at 1000 rpm and 20 A, sampled at the DAQ rate; printed for the Table I motor and
again with the optional motor imperfections (5th/7th EMF harmonics and cogging). The batch
varies speed and current over 16 full drives (with imperfections) and runs them with
``simulate_batch`` (numba prange over every core). The first calls' compile or cache-load time
is printed apart; the figures are the median of ``--repeats`` runs, wall and CPU seconds of this
process (on a shared machine the CPU figure is the one other load does not inflate; the load
average is printed before and after). The Table I drive is also timed at a 1 MHz output rate,
where writing the samples, not the PWM periods, dominates; and, at 20 kHz and at 1 MHz, with
only the three channels a ripple plan needs (``time_s``, ``rotor_angle_mech_rad``,
``torque_nm``: the engine computes nothing else per sample, issue 17 item 4). ``--parts``
also prints the compiled loop alone (no samples, ns per PWM period) and, in isolation (a compiled
loop of calls, ns per call, min of the repeats), the parts it is made of: the firmware step, the
per-period EMF basis, the forced response/EMF at one instant (once per sub-segment boundary)
and one small-argument exponential.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numba
import numpy as np
from numba import njit

from hil.sim import DriveConfig, Injection, MotorModel, simulate, simulate_batch
from hil.sim.electrical import (BASIS_COLUMNS, FAST_MATH, MAX_HARMONICS, evaluate, exp_small,
                                harmonic_table, impedance_angles, period_basis)
from hil.sim.firmware import ANGLE_CACHE_ROWS, A_INDEX, firmware_constants, firmware_step
from hil.sim.kernel import run_drive
from hil.sim.layout import N_CHANNELS, P_PWM_COUNTS, P_PWM_FREQ
from hil.sim.packing import new_state, pack_params
from hil.sim.results import NO_ROWS


#: what a ripple plan's analysis reads (the torque against the rotor angle, and the time base)
PLAN_CHANNELS = ("time_s", "rotor_angle_mech_rad", "torque_nm")


def full_drive(speed_rpm: float = 1000.0, current_a: float = 20.0,
               imperfect_motor: bool = True) -> DriveConfig:
    injection = Injection(ia_offset_a=0.2, ib_offset_a=-0.1, ia_gain_error_pu=0.01,
                          ib_gain_error_pu=-0.01, encoder_decimation=10, word_length_bits=16,
                          pwm_period_counts=2000, pwm_frequency_hz=20000.0, dead_time_s=1e-6,
                          current_angle_rad=0.2)
    motor = MotorModel(emf_harmonics=((5, 0.01, 0.0), (7, 0.005, 0.0)),
                       cogging=((24, 0.005, 0.0),)) if imperfect_motor else MotorModel()
    return DriveConfig(motor=motor, injection=injection, current_command_a=current_a,
                       speed_rpm=speed_rpm)


def median_of(repeats: int, call, clock=time.perf_counter) -> float:
    """Median of ``repeats`` calls on ``clock`` (wall by default; ``time.process_time`` gives
    the CPU seconds of this process, which other load on a shared machine does not inflate)."""
    times = []
    for _ in range(repeats):
        start = clock()
        call()
        times.append(clock() - start)
    return statistics.median(times)


@njit(cache=True, fastmath=False)
def _firmware_calls(params, state, theta_m, ia_a, ib_a):
    constants = firmware_constants(params)
    cache = np.empty((ANGLE_CACHE_ROWS, 7))
    cache[:, A_INDEX] = -1.0
    total = 0.0
    for i in range(theta_m.size):
        total += firmware_step(ia_a[i], ib_a[i], theta_m[i], 104.7, params, state,
                               params[P_PWM_COUNTS], constants, cache)[0]
    return total


@njit(cache=True, fastmath=FAST_MATH)
def _harmonics(params, omega_m):
    orders, amplitudes, phases = np.zeros(MAX_HARMONICS), np.zeros(MAX_HARMONICS), \
        np.zeros(MAX_HARMONICS)
    count = harmonic_table(params, orders, amplitudes, phases)
    lag = np.zeros((MAX_HARMONICS, 3))
    impedance_angles(params, omega_m, orders, amplitudes, count, lag)
    return orders, amplitudes, phases, count, lag


@njit(cache=True, fastmath=FAST_MATH)
def _basis_calls(params, theta_e):
    orders, amplitudes, phases, count, lag = _harmonics(params, 104.7)
    basis = np.zeros((MAX_HARMONICS, BASIS_COLUMNS))
    total = 0.0
    for i in range(theta_e.size):
        period_basis(params, theta_e[i], orders, amplitudes, phases, count, lag, basis)
        total += basis[0, 1]
    return total


@njit(cache=True, fastmath=FAST_MATH)
def _evaluate_calls(params, tau):
    orders, amplitudes, phases, count, lag = _harmonics(params, 104.7)
    basis = np.zeros((MAX_HARMONICS, BASIS_COLUMNS))
    period_basis(params, 0.3, orders, amplitudes, phases, count, lag, basis)
    total = 0.0
    for i in range(tau.size):
        fa, _, _, _, kb, _ = evaluate(tau[i], 4 * 104.7, orders, count, basis)
        total += fa + kb
    return total


@njit(cache=True, fastmath=FAST_MATH)
def _exp_calls(x):
    total = 0.0
    for i in range(x.size):
        total += exp_small(x[i])
    return total


def print_parts(repeats: int) -> None:
    """The compiled loop alone and its parts in isolation (see the module docstring)."""
    for imperfect, label in ((False, "Table I motor"), (True, "+ EMF harmonics, cogging")):
        params = pack_params(full_drive(imperfect_motor=imperfect))
        seconds = 0.5
        periods = seconds * params[P_PWM_FREQ]

        def loop():
            run_drive(params, new_state(), 0.0, 1.0, np.zeros((0, 0)), NO_ROWS,
                      np.zeros(N_CHANNELS), seconds)
        loop()
        best = min(median_of(1, loop, time.process_time) for _ in range(repeats))
        print(f"parts, {label}: compiled loop without samples {best / periods * 1e9:.0f} ns "
              f"per PWM period ({best / seconds:.4f} CPU s per simulated s)")
        n = 200_000
        rng = np.random.default_rng(0)
        theta = np.cumsum(np.full(n, 104.7 / 20e3))
        angle = 4 * theta
        calls = {
            "firmware_step": lambda: _firmware_calls(params, new_state(), theta,
                                                     20 * np.sin(angle),
                                                     20 * np.sin(angle - 2.0944)),
            "period_basis": lambda: _basis_calls(params, angle),
            "evaluate (one instant)": lambda: _evaluate_calls(params, rng.uniform(0, 5e-5, n)),
            "exp_small": lambda: _exp_calls(rng.uniform(-0.3, 0.0, n)),
        }
        for name, call in calls.items():
            call()
            best = min(median_of(1, call, time.process_time) for _ in range(repeats))
            print(f"parts, {label}: {name:<24} {best / n * 1e9:.1f} ns per call (isolated)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per run")
    parser.add_argument("--daq-rate-hz", type=float, default=20_000.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--parts", action="store_true",
                        help="also time the compiled loop alone and its parts in isolation")
    args = parser.parse_args()

    start = time.perf_counter()
    simulate(full_drive(), 0.001, args.daq_rate_hz)
    simulate_batch([full_drive(), full_drive()], 0.001, args.daq_rate_hz)
    print(f"first calls (compile or cache load): {time.perf_counter() - start:.2f} s")
    print(f"cores: {os.cpu_count()}, numba threads: {numba.get_num_threads()}, "
          f"load average: {os.getloadavg()[0]:.2f}")

    for imperfect, label in ((False, "Table I motor"), (True, "+ EMF harmonics, cogging")):
        config = full_drive(imperfect_motor=imperfect)
        wall = median_of(args.repeats, lambda: simulate(config, args.seconds, args.daq_rate_hz))
        cpu = median_of(args.repeats, lambda: simulate(config, args.seconds, args.daq_rate_hz),
                        time.process_time)
        print(f"one drive, one core, {label:<24}: {wall / args.seconds:.4f} wall s per "
              f"simulated s ({args.seconds / wall:.0f}x real time; issue 17 goal <= 0.006), "
              f"{cpu / args.seconds:.4f} CPU s")
    config = full_drive(imperfect_motor=False)
    for rate_hz, seconds, channels, label in (
            (args.daq_rate_hz, args.seconds, PLAN_CHANNELS, "3 channels"),
            (1e6, args.seconds / 10.0, None, "1 MHz output"),
            (1e6, args.seconds / 10.0, PLAN_CHANNELS, "1 MHz output, 3 channels")):
        def run():
            simulate(config, seconds, rate_hz, channels=channels)
        wall = median_of(args.repeats, run)
        cpu = median_of(args.repeats, run, time.process_time)
        print(f"one drive, one core, Table I motor, {label:<24}: {wall / seconds:.4f} wall s per "
              f"simulated s, {cpu / seconds:.4f} CPU s")

    configs = [full_drive(speed_rpm=200.0 + 100.0 * (k % 8), current_a=10.0 + 10.0 * (k // 8))
               for k in range(16)]
    wall = median_of(args.repeats,
                     lambda: simulate_batch(configs, args.seconds, args.daq_rate_hz))
    print(f"batch of 16, all cores: {wall / args.seconds:.4f} wall s per simulated s of the "
          f"batch, {wall / args.seconds / 16:.4f} per drive-second "
          f"({16 * args.seconds / wall:.0f}x real time per drive)")
    if args.parts:
        print_parts(max(args.repeats, 5))
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
