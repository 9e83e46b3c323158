"""Named unit conversions (to SI). Multiply a datasheet value by the constant to get SI."""

import math

DEG = math.pi / 180.0               # deg -> rad
DPS = DEG                           # deg/s -> rad/s
DPH = DEG / 3600.0                  # deg/h -> rad/s
DEG_RT_H = DEG / 60.0               # deg/sqrt(h) -> rad/sqrt(s)   (angle random walk)
DPH_RT_H = DEG / 3600.0 / 60.0      # deg/h/sqrt(h) -> rad/s/sqrt(s) (rate random walk)
DPH_PER_H = DEG / 3600.0 / 3600.0   # deg/h/h -> rad/s^2           (rate ramp)
ARCSEC = DEG / 3600.0               # arcsec -> rad                 (quantisation)
PPM = 1e-6                          # ppm -> 1
G0 = 9.80665                        # standard gravity, m/s^2
EARTH_RATE = 7.2921150e-5           # rad/s, the Earth's rotation rate (WGS-84)
