"""5-axis tool orientation: per CC point the feasible tool axes over (lead, tilt) where the real
tool neither gouges nor collides, their boundary, and the best axis (docs/MATH.md §10)."""
