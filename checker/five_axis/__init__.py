"""5-axis (multi-axis) jobs: the machine's motion between poses (`motion`); per CC point the
feasible tool axes over (lead, tilt) where the real tool neither gouges nor collides, their
boundary and the best axis (docs/MATH.md §10); the tool axis along a path (`posture`)."""
