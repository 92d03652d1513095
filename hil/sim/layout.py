"""Index layout of the flat arrays the compiled engine works on (parameters, state, outputs).

The compiled loop takes no Python objects: ``hil.sim.packing`` writes a ``DriveConfig`` into a
parameter vector with these indices, and the engine state/output arrays use the ones below.
"""

# ---- parameter vector (float64) ----
P_R = 0                  # phase resistance, ohm
P_L = 1                  # phase inductance, H
P_VDC = 2                # dc bus, V
P_POLE_PAIRS = 3
P_PSI = 4                # peak EMF per mechanical rad/s (sqrt(2)·Ke), V·s/rad
P_NEUTRAL = 5            # 1: neutral tied to the dc-bus midpoint, 0: isolated
P_N_HARM = 6             # number of EMF harmonics used (<= 4)
P_HARM = 7               # 4 × (order, amplitude pu, phase rad) -> indices 7..18
P_N_COG = 19             # number of cogging terms (<= 2)
P_COG = 20               # 2 × (mech order, amplitude N·m, phase rad) -> 20..25
P_PWM_FREQ = 26          # Hz
P_PWM_COUNTS = 27        # counter top value N (counts per half period)
P_DEAD_TIME = 28         # s
P_MODULATION = 29        # 0 svpwm, 1 sine
P_KP_PU = 30             # PI proportional gain, per unit (V_base/I_base), already quantised
P_KI_TS_PU = 31          # PI integral gain × T_s, per unit, already quantised
P_TABLE_SIZE = 32
P_WORD_BITS = 33         # 0 = float
P_ADC_BITS = 34
P_ADC_FS = 35            # A (also the firmware's current base I_base)
P_IA_OFFSET = 36         # A
P_IB_OFFSET = 37
P_IA_GAIN = 38           # gain error, pu
P_IB_GAIN = 39
P_ENC_CPR = 40
P_ENC_DECIM = 41
P_HALL = 42
P_IQ_CMD = 43            # commanded q current I·cos φ, A (φ: current lags the EMF, eq 4)
P_ID_CMD = 44            # commanded d current −I·sin φ, A
P_ENABLED = 45
P_SPEED_CMD = 46         # rpm
P_DYNO_MODE = 47         # 0 constant, 1 ramp, 2 stepping
P_RAMP = 48              # rpm/s
P_STEP_ANGLE = 49        # mech rad
P_DWELL = 50             # s
P_TR_TAU = 51            # transducer time constant, s
P_MERGE_SEGMENTS = 52    # 1: skip boundaries where no leg voltage changes (0 only to test that)
P_LOOP_DELAY = 53        # current-loop computation delay, PWM periods: 0, 0.5, 1 or 1.5
P_DECOUPLE_PU = 54       # decoupling: ωe·L per unit of V_base/I_base, per mech rad/s (0: off)
P_EMF_FF_PU = 55         # EMF feed-forward: peak EMF per unit of V_base, per mech rad/s (0: off)
P_ANGLE_ADVANCE = 56     # inverse-Park angle advanced by ωe × this, s (0: no compensation)
P_L_SAT = 57             # saturation current i_sat of L(i) = L/(1 + (|i|/i_sat)²), A (0: linear)
P_WARM_TAU = 58          # winding thermal time constant, s (0: the winding does not warm)
P_WARM_RISE = 59         # steady-state rise of R per unit of R, per A² of the current vector |i|²
P_TEST_AMP_PU = 60       # loop test signal amplitude on the q reference, per unit of I_base (0: off)
P_TEST_ORDER = 61        # its electrical order k
N_PARAMS = 62

# ---- state vector (float64), at a PWM period boundary ----
S_TIME = 0               # s, start of the next period
S_THETA_M = 1            # rotor mechanical angle, rad (unwrapped)
S_OMEGA_M = 2            # speed of the last period, rad/s
S_IA = 3
S_IB = 4
S_IC = 5
S_INT_D = 6              # PI integrators, per unit of V_base (= V_dc)
S_INT_Q = 7
S_CMP_A = 8              # compare values latched for the coming period (-1: gates off)
S_CMP_B = 9
S_CMP_C = 10
S_TR_Y = 11              # transducer filter output, N·m
S_ISENSE_A = 12          # last sensed currents (A, as the firmware read them)
S_ISENSE_B = 13
S_INITIALISED = 14
S_HIGH_END = 15          # 3 flags: leg x ended the last period high (full duty, no edge)
S_CMP_PENDING = 18       # 3 compare values computed, waiting a period more (1.5-period delay)
S_WARM = 21              # winding resistance rise, per unit of the cold R (the thermal state)
N_STATE = 22

# ---- output channels (rows of the output array) ----
C_TIME = 0
C_THETA_M = 1
C_COUNTS = 2
C_IA = 3
C_IB = 4
C_IC = 5
C_TORQUE_EM = 6
C_TORQUE_SHAFT_FILTERED = 7   # transducer front end before gain error and noise
C_SPEED_RPM = 8
C_ID = 9
C_IQ = 10
C_VA = 11
C_VB = 12
C_VC = 13
C_IA_SENSED = 14
C_IB_SENSED = 15
C_TORQUE_SHAFT = 16           # electromagnetic + cogging torque
N_CHANNELS = 17
