"""5-axis (multi-axis) jobs: the machine's motion between poses, orientations, feasibility."""
