"""5-axis (multi-axis) jobs: the machine's motion between poses (`motion`); per CC point the
feasible tool axes over (lead, tilt) where the real tool neither gouges nor collides, their
boundary and the best axis (docs/MATH.md §10); flat-end positioning by the order of contact
(`contact_order`, §11); the tool axis along a path (`posture`) and the re-orientation of an
operation (`plan`) (§13)."""
