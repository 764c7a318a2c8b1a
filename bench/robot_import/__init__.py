"""Import a user's MJCF or URDF humanoid: fit it to the planner, write a robot spec.

``fit.fit_model`` compiles the model with MuJoCo, finds both legs' hip pitch, knee,
ankle pitch and ankle roll, and checks that the legs are the planner's; ``lump``
lumps the bodies into the spec's five links; ``write`` turns both into a spec TOML
and a report of every approximation with its size.
"""
