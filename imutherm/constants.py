"""Physical constants used in more than one stage, defined once."""

#: 0 °C in kelvin [K] (the 2019 SI: T [K] = t [°C] + 273.15, exact); absolute zero is -ZERO_C_K °C
ZERO_C_K = 273.15

#: standard gravity [m/s^2] (3rd CGPM 1901; ISO 80000-3): the accelerometers' g unit and the natural-convection
#: buoyancy
STANDARD_GRAVITY = 9.80665
