"""Physical constants used in more than one stage, defined once."""

#: standard gravity [m/s^2] (3rd CGPM 1901; ISO 80000-3): the accelerometers' g unit and the natural-convection
#: buoyancy
STANDARD_GRAVITY = 9.80665
