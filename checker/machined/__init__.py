"""The machined part against the design: the simulated stock's surface compared with the part's
(docs/MATH.md §15)."""
