"""Write a ``DriveConfig`` into the flat parameter vector of the compiled engine (see layout)."""

from __future__ import annotations

import math

import numpy as np

from hil.sim import layout as L
from hil.sim.config import DYNO_MODES, DriveConfig
from hil.sim.firmware import quantise_gain


def pack_params(config: DriveConfig) -> np.ndarray:
    """The float64 parameter vector for ``config`` (gains already scaled and quantised)."""
    p = np.zeros(L.N_PARAMS)
    motor = config.motor.parameters
    injection = config.injection
    p[L.P_R] = motor.phase_resistance_ohm
    p[L.P_L] = motor.phase_inductance_h
    p[L.P_VDC] = motor.dc_bus_v
    p[L.P_POLE_PAIRS] = motor.pole_pairs
    p[L.P_PSI] = motor.emf_peak_v_s_per_rad
    p[L.P_NEUTRAL] = 1.0 if config.motor.neutral_connected else 0.0
    p[L.P_N_HARM] = len(config.motor.emf_harmonics)
    for k, (order, amplitude, phase) in enumerate(config.motor.emf_harmonics):
        p[L.P_HARM + 3 * k:L.P_HARM + 3 * k + 3] = (order, amplitude, phase)
    p[L.P_N_COG] = len(config.motor.cogging)
    for k, (order, amplitude, phase) in enumerate(config.motor.cogging):
        p[L.P_COG + 3 * k:L.P_COG + 3 * k + 3] = (order, amplitude, phase)

    p[L.P_PWM_FREQ] = injection.pwm_frequency_hz
    p[L.P_PWM_COUNTS] = injection.pwm_period_counts
    p[L.P_DEAD_TIME] = injection.dead_time_s
    p[L.P_MODULATION] = 0.0 if config.inverter.modulation == "svpwm" else 1.0

    bits = int(injection.word_length_bits)
    model = config.motor
    p[L.P_L_SAT] = model.saturation_current_a
    p[L.P_WARM_TAU] = model.thermal_time_constant_s
    p[L.P_WARM_RISE] = model.resistance_rise_pu_per_a2
    tuned = config.firmware.tuning or motor     # the motor the firmware's gains were set for
    kp_v_per_a, ki_v_per_a_s = config.firmware.gains(tuned, injection.pwm_frequency_hz)
    current_base_a = config.sensors.adc_full_scale_a
    voltage_base_v = motor.dc_bus_v
    to_pu = current_base_a / voltage_base_v
    p[L.P_KP_PU] = quantise_gain(kp_v_per_a * to_pu, bits)
    p[L.P_KI_TS_PU] = quantise_gain(ki_v_per_a_s / injection.pwm_frequency_hz * to_pu, bits)
    p[L.P_TABLE_SIZE] = config.firmware.sine_table_size
    p[L.P_WORD_BITS] = bits

    p[L.P_ADC_BITS] = config.sensors.adc_bits
    p[L.P_ADC_FS] = current_base_a
    p[L.P_IA_OFFSET] = injection.ia_offset_a
    p[L.P_IB_OFFSET] = injection.ib_offset_a
    p[L.P_IA_GAIN] = injection.ia_gain_error_pu
    p[L.P_IB_GAIN] = injection.ib_gain_error_pu
    p[L.P_ENC_CPR] = config.sensors.encoder_counts_per_rev
    p[L.P_ENC_DECIM] = injection.encoder_decimation
    p[L.P_HALL] = 1.0 if injection.hall_mode else 0.0

    p[L.P_TEST_AMP_PU] = injection.loop_test_amplitude_a / current_base_a
    p[L.P_TEST_ORDER] = injection.loop_test_order
    p[L.P_IQ_CMD] = config.current_command_a * math.cos(injection.current_angle_rad)
    p[L.P_ID_CMD] = -config.current_command_a * math.sin(injection.current_angle_rad)
    p[L.P_ENABLED] = 1.0 if config.enabled else 0.0
    p[L.P_SPEED_CMD] = config.speed_rpm
    p[L.P_DYNO_MODE] = DYNO_MODES.index(config.dyno.mode)
    p[L.P_RAMP] = config.dyno.ramp_rpm_per_s
    p[L.P_STEP_ANGLE] = config.dyno.step_mech_rad
    p[L.P_DWELL] = config.dyno.dwell_s
    p[L.P_TR_TAU] = 1.0 / (2.0 * math.pi * config.transducer.bandwidth_hz)
    p[L.P_MERGE_SEGMENTS] = 1.0
    firmware = config.firmware
    p[L.P_LOOP_DELAY] = firmware.delay_periods
    if firmware.decoupling:                  # ωe·L·I_base/V_base per mechanical rad/s
        p[L.P_DECOUPLE_PU] = tuned.pole_pairs * tuned.phase_inductance_h * to_pu
    if firmware.emf_feedforward:             # peak EMF per V_base, per mechanical rad/s
        p[L.P_EMF_FF_PU] = tuned.emf_peak_v_s_per_rad / voltage_base_v
    if firmware.angle_compensation:
        p[L.P_ANGLE_ADVANCE] = firmware.total_delay_s(injection.pwm_frequency_hz)
    return p


def new_state() -> np.ndarray:
    """Engine state of a drive at rest at t = 0 (gates off until the firmware's first period)."""
    return np.zeros(L.N_STATE)
