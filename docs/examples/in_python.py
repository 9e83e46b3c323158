"""fogcomp in Python on real logs: the example of the guide "Your own gyro log".

Run from the repository's root, with the real logs beside it in ../shared/realdata:

    .venv/bin/python docs/examples/in_python.py
"""

import math

import numpy as np
import pandas as pd

import fogcomp
from fogcomp.allan import allan_analysis
from fogcomp.calibration import ferraris_calibration

# Allan analysis and noise identification of a static log (SI inside: rad/s, Hz)
log = pd.read_csv("../shared/realdata/adis16405_static/imu1.csv.gz")
rate_rad_s = np.radians(log["gyro_x_dps"].to_numpy())
curve, model = allan_analysis(rate_rad_s, fs=100.0)   # AllanCI, fogcomp.noise.NoiseModel
arw = model.term("N")
print(model.spec(), arw.value, arw.low, arw.high)      # N in rad/sqrt(s)
print(model.to_datasheet()["terms"][1])                # N in datasheet units
gm = model.term("GM")            # the Gauss-Markov term; not selected here: its 95 % bound
print(gm.status, gm.bound_by_tau[:3])                  # (T s, sigma bound rad/s) per T
print(model.filter_parameters()[0])                    # what a Kalman filter needs, SI

# the six-position + three-rotation triad calibration of a raw session
s = pd.read_csv("../shared/realdata/imucal_ferraris/annotated_session.csv")
acc = {p: g[["acc_x", "acc_y", "acc_z"]].to_numpy(float) for p, g in s.groupby("part")}
gyro = {p: g[["gyr_x", "gyr_y", "gyr_z"]].to_numpy(float) for p, g in s.groupby("part")}
cal = ferraris_calibration(acc, gyro, fs=204.8, angle=-2 * math.pi, g=9.81)
w_rad_s, f_mps2 = cal.calibrate(gyro["z_p"], acc["z_p"])   # (n, 3) each
print(np.degrees(w_rad_s.mean(axis=0)), f_mps2.mean(axis=0))

# a supervised method: learn the error rate - reference from temperature, then remove it
rng = np.random.default_rng(0)
t = np.arange(36_000.0)                                # 10 h at 1 Hz
temp_c = 20 + 20 * np.sin(2 * np.pi * t / 36_000)
dtdt_c_per_s = np.gradient(temp_c)
reference_rate = np.zeros_like(t)                      # at rest, Earth rate removed
rate = 1e-6 * (temp_c - 20) + 2e-4 * dtdt_c_per_s + rng.normal(0, 1e-6, t.size)
data = fogcomp.GyroData(rate=rate, fs=1.0, temp=temp_c, temp_rate=dtdt_c_per_s)
model = fogcomp.make_method("poly_temp").fit(data, reference_rate)
clean = model.compensate(data)                         # rad/s
print(np.std(rate), np.std(clean))
model.save("out/my_model")        # out/my_model.json + .npz: no pickle, SHA-256 over both
print(fogcomp.load_model("out/my_model"))
