"""Robot models from URDF + TOML, elastostatic calibration and model diagnosis."""
