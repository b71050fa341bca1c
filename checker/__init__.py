"""pathcheck engine: CL reading, part geometry, cutter models, allowable-cutter search, 4-axis
orientation, verdicts, results store and report. Units: mm and radians inside unless stated."""

__version__ = "0.1.0"
